//! The command line: one module per command, each a leaf that nothing
//! outside this folder names, plus what several commands share: the
//! rendering options (`options`), the flags' value types and parsers
//! (`values`), several scenes in one command (`batch`), where pictures go
//! (`output`) and the status lines (`status`). Every clap type lives here.
//! `main.rs` parses, calls [`run`], and is the one place that prints an
//! error and chooses the exit code (`crate::error::EXIT_CODES`).

mod batch;
mod bench;
mod check;
mod compare;
mod conformance;
mod devices;
mod explain;
mod gen;
mod info;
mod mitsuba;
mod options;
mod output;
mod pov;
mod preview;
mod render;
mod shader_test;
mod status;
mod trace;
mod values;
mod versus;

use clap::{Parser, Subcommand};

/// `raycast`: the global flags and the command.
#[derive(Parser, Debug)]
#[command(
    name = "raycast",
    version,
    about = "A ray caster in a Vulkan compute shader for CS1230/CS123/Comp175 XML scenes",
    after_help = crate::error::exit_codes_help()
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Say more on stderr: device, scene, times, rates, kernel.
    #[arg(short, long, global = true, conflicts_with = "quiet", help_heading = "Diagnostics")]
    verbose: bool,
    /// Say nothing on stderr but warnings and errors.
    #[arg(short, long, global = true, help_heading = "Diagnostics")]
    quiet: bool,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render scenes to PNGs (the embedded default scene when none is given).
    ///
    /// Several scenes go one after the other on one device, its start-up and each kernel paid once.
    Render(render::RenderArgs),
    /// Render on the device and on the CPU build and compare every buffer bit for bit.
    Check(check::CheckArgs),
    /// Show a scene in a window, refined while still, reloaded when its file or the shaders change.
    Preview(preview::PreviewArgs),
    /// Compare two pictures (say, your render and a course reference): how many
    /// pixels differ by more than a tolerance, the first and the worst.
    Compare(compare::CompareArgs),
    /// Why a picture differs from raycast's render of its scene: the likely causes, where, and how well each fits.
    ///
    /// raycast draws its own reference as the course drew the picture's size, and tries the mistakes it knows
    /// (a lighting term left out or doubled, flipped normals, a texture upside down, half a pixel off, …), each
    /// drawn on purpose: the one the picture matches where the reference does not is the likely cause.
    Explain(explain::ExplainArgs),
    /// Run shader unit tests (tests/shaders/*.toml by default) on the device and the CPU build.
    ShaderTest(shader_test::ShaderTestArgs),
    /// Follow one sample of one pixel through the shared code (its CPU build), step by step: each ray and what it meets, each light's term and shadow ray, each level's colour and mirror weight.
    // Hidden from its help: the options of the renders it shares that
    // trace refuses (a device's, the AOVs'), which it would list otherwise.
    #[command(
        mut_arg("device", |a| a.hide(true)),
        mut_arg("shaders", |a| a.hide(true)),
        mut_arg("scene_buffers", |a| a.hide(true)),
        mut_arg("validate", |a| a.hide(true)),
        mut_arg("timeout", |a| a.hide(true)),
        mut_arg("aov", |a| a.hide(true)),
        mut_arg("depth_range", |a| a.hide(true)),
        mut_arg("cost_max", |a| a.hide(true))
    )]
    Trace(trace::TraceArgs),
    /// Describe scenes without rendering them: camera, primitives, lights, materials, the world box, each group's hierarchy (nodes, leaves, depth, SAH cost) and buffer sizes
    Info(info::InfoArgs),
    /// List the Vulkan devices.
    Devices,
    /// Write a scale-test scene: the corpus's recursive spheres, cones or cubes, N levels deep, or a mesh sphere.
    Gen(gen::GenArgs),
    /// Time scenes per backend: median frame time, ray rates, primitives, memory.
    Bench(bench::BenchArgs),
    /// Render every scene of the course's corpus as its official reference was made, and compare under a stated rule.
    Conformance(conformance::ConformanceArgs),
    /// Write a scene in POV-Ray 3.7's scene language (masters as declared objects), to time or view it beside POV-Ray.
    Pov(pov::PovArgs),
    /// Write a scene in Mitsuba 3's XML format (nested masters split into shape groups and instances), to time or view it beside Mitsuba 3.
    Mitsuba(mitsuba::MitsubaArgs),
}

/// Runs the command `cli` names.
pub fn run(cli: Cli) -> Result<(), crate::error::Error> {
    crate::set_verbosity(match (cli.quiet, cli.verbose) {
        (true, _) => crate::Verbosity::Quiet,
        (_, true) => crate::Verbosity::Verbose,
        _ => crate::Verbosity::Summary,
    });
    match cli.command {
        Command::Render(args) => render::run(&args),
        Command::Check(args) => check::run(&args),
        Command::Compare(args) => compare::run(&args),
        Command::Explain(args) => explain::run(&args),
        Command::Preview(args) => preview::run(&args),
        Command::Info(args) => info::run(&args),
        Command::Trace(args) => trace::run(&args),
        Command::Devices => devices::run(),
        Command::ShaderTest(args) => shader_test::run(&args),
        Command::Gen(args) => gen::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Conformance(args) => conformance::run(&args),
        Command::Pov(args) => pov::run(&args),
        Command::Mitsuba(args) => mitsuba::run(&args),
    }
}
