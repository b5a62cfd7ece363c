//! `mbs`: the DEM numerical movable bed (Gotoh, Harada & Sakai). The
//! command line lives in the library ([`mbs::cli`]), one file per
//! subcommand, so that it is documented and tested with the rest.

fn main() -> std::process::ExitCode {
    mbs::cli::main()
}
