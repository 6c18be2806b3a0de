fn main() -> std::process::ExitCode {
    metamer::cli::main()
}
