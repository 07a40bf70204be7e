//! The one question the preview asks the X server itself: whether the
//! display has an extension. Through libX11, loaded at run time as GLFW
//! loads it (raycast links no X library), on a connection of its own.

use std::ffi::{c_char, c_int, c_void, CStr};

type OpenDisplay = unsafe extern "C" fn(*const c_char) -> *mut c_void;
type QueryExtension = unsafe extern "C" fn(*mut c_void, *const c_char, *mut c_int, *mut c_int, *mut c_int) -> c_int;
type CloseDisplay = unsafe extern "C" fn(*mut c_void) -> c_int;

/// Whether the X display of `$DISPLAY` offers the extension `name` (XQueryExtension);
/// an error where libX11 cannot be loaded or the display opened.
pub fn display_has_extension(name: &CStr) -> Result<bool, String> {
    // SAFETY: libX11's initialisers are safe to run; the symbols are used with their C signatures.
    unsafe {
        let lib = libloading::Library::new("libX11.so.6").map_err(|e| format!("cannot load libX11.so.6: {e}"))?;
        let open: libloading::Symbol<OpenDisplay> = lib.get(b"XOpenDisplay\0").map_err(|e| e.to_string())?;
        let query: libloading::Symbol<QueryExtension> = lib.get(b"XQueryExtension\0").map_err(|e| e.to_string())?;
        let close: libloading::Symbol<CloseDisplay> = lib.get(b"XCloseDisplay\0").map_err(|e| e.to_string())?;
        let display = open(std::ptr::null());
        if display.is_null() {
            return Err("cannot open the X display".into());
        }
        let (mut opcode, mut event, mut error) = (0, 0, 0);
        let has = query(display, name.as_ptr(), &mut opcode, &mut event, &mut error) != 0;
        close(display);
        Ok(has)
    }
}
