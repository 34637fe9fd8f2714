//! The `wedge` binary: the command line of [`wedge::cli`] over the nodes and kernels wedge ships.

fn main() -> std::process::ExitCode {
    wedge::cli::main(wedge::Registries::builtin())
}
