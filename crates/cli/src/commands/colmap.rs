use clap::Subcommand;

#[derive(Subcommand)]
pub enum Command {
    /// Print a summary.
    Info { dir: std::path::PathBuf },
}

pub fn run(cmd: Command) -> anyhow::Result<()> {
    match cmd {
        Command::Info { dir } => anyhow::bail!("colmap info {}: not built yet", dir.display()),
    }
}
