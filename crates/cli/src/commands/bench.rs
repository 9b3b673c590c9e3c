use clap::Subcommand;

#[derive(Subcommand)]
pub enum Command {
    /// Reading a large binary COLMAP model, against pycolmap when available.
    Colmap,
}

pub fn run(cmd: Command) -> anyhow::Result<()> {
    match cmd {
        Command::Colmap => anyhow::bail!("bench colmap: not built yet"),
    }
}
