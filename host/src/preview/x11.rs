//! The one question the preview asks the X server itself: which of some
//! extensions the display has. Through libX11, loaded at run time as GLFW
//! loads it (raycast links no X library), on a connection of its own.

use std::ffi::{c_char, c_int, c_void, CStr};

type OpenDisplay = unsafe extern "C" fn(*const c_char) -> *mut c_void;
type QueryExtension = unsafe extern "C" fn(*mut c_void, *const c_char, *mut c_int, *mut c_int, *mut c_int) -> c_int;
type CloseDisplay = unsafe extern "C" fn(*mut c_void) -> c_int;

/// Which of `names` the X display `display` (None: `$DISPLAY`'s) offers
/// (XQueryExtension, on one connection); an error where libX11 cannot be
/// loaded or the display opened.
pub fn display_extensions(display: Option<&CStr>, names: &[&CStr]) -> Result<Vec<bool>, String> {
    // SAFETY: libX11's initialisers are safe to run; the symbols are used with their C signatures.
    unsafe {
        let lib = libloading::Library::new("libX11.so.6").map_err(|e| format!("cannot load libX11.so.6: {e}"))?;
        let open: libloading::Symbol<OpenDisplay> = lib.get(b"XOpenDisplay\0").map_err(|e| e.to_string())?;
        let query: libloading::Symbol<QueryExtension> = lib.get(b"XQueryExtension\0").map_err(|e| e.to_string())?;
        let close: libloading::Symbol<CloseDisplay> = lib.get(b"XCloseDisplay\0").map_err(|e| e.to_string())?;
        let connection = open(display.map_or(std::ptr::null(), CStr::as_ptr));
        if connection.is_null() {
            return Err("cannot open the X display".into());
        }
        let has = names
            .iter()
            .map(|name| {
                let (mut opcode, mut event, mut error) = (0, 0, 0);
                query(connection, name.as_ptr(), &mut opcode, &mut event, &mut error) != 0
            })
            .collect();
        close(connection);
        Ok(has)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{BufRead, BufReader};
    use std::process::{Command, Stdio};

    /// An Xvfb of its own (the Debian package the preview's tests need):
    /// it has BIG-REQUESTS, as every X server, and neither NV-GLX nor DRI3
    /// (the display the preview refuses NVIDIA's driver), nor a made-up name.
    #[test]
    fn asks_the_display() {
        let mut xvfb = Command::new("Xvfb")
            .args(["-displayfd", "1", "-noreset", "-nolisten", "tcp", "-screen", "0", "64x64x24"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb (Debian package xvfb) runs");
        let mut line = String::new();
        BufReader::new(xvfb.stdout.take().expect("piped")).read_line(&mut line).expect("Xvfb says its display");
        let display = std::ffi::CString::new(format!(":{}", line.trim())).expect("a display name");
        let names = [c"BIG-REQUESTS", c"NV-GLX", c"DRI3", c"NO-SUCH-EXTENSION-RAYCAST"];
        let answers = display_extensions(Some(&display), &names);
        let _ = xvfb.kill();
        let _ = xvfb.wait();
        assert_eq!(answers, Ok(vec![true, false, false, false]), "display {display:?}");
        assert!(display_extensions(Some(c":9999"), &names).is_err(), "no display there");
    }
}
