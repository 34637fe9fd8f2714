//! `wedge-fog`: every subcommand and flag of `wedge` (render, reference, parity, bench, graph, view,
//! …) with the Fog node added.

fn main() -> std::process::ExitCode {
    wedge::cli::main(wedge_fog::registries())
}
