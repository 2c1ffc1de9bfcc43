fn main() -> std::process::ExitCode {
    tprf::cli::main()
}
