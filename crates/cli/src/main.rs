//! `raylume`: renders p3f scenes from the command line (see the `raylume_cli` library for what
//! each command does and checks).

fn main() -> std::process::ExitCode {
    raylume_cli::run()
}
