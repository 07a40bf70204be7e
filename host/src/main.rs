fn main() -> std::process::ExitCode {
    raycast::cli::main()
}
