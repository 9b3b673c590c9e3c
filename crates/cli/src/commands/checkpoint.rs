//! `pl2map checkpoint import REF.pth --out model.ckpt`: the reference implementation's
//! released PL2Map model as this project's checkpoint (`train::import_reference`).

use anyhow::Context;
use clap::Subcommand;
use std::path::PathBuf;

#[derive(Subcommand)]
pub enum Command {
    /// Import the reference implementation's released model (a PyTorch state dict of its
    /// PL2Map module at D = 256, SuperPoint descriptors) for `pl2map score` / `localize`.
    Import(ImportArgs),
}

#[derive(clap::Args, Debug)]
pub struct ImportArgs {
    /// The reference's model file (`*.pth.tar` with `model_state_dict`, or a bare state dict).
    pub reference: PathBuf,
    /// Checkpoint to write.
    #[arg(long)]
    pub out: PathBuf,
    /// SuperPoint weights (`superpoint_v1.pth`) the query front-end uses; default:
    /// PL2MAP_SUPERPOINT_WEIGHTS.
    #[arg(long)]
    pub superpoint_weights: Option<PathBuf>,
}

pub fn run(cmd: Command) -> anyhow::Result<()> {
    match cmd {
        Command::Import(a) => import(a),
    }
}

fn import(args: ImportArgs) -> anyhow::Result<()> {
    let s = train::import_reference::import_reference(
        &args.reference,
        &args.out,
        args.superpoint_weights.as_deref(),
    )
    .with_context(|| format!("importing {}", args.reference.display()))?;
    crate::outln!(
        "{}: {} tensors, {} parameters{} -> {} (SuperPoint weights {}, sha256 {})",
        args.reference.display(),
        s.tensors,
        s.parameters,
        if s.nested {
            " (under model_state_dict)"
        } else {
            ""
        },
        args.out.display(),
        s.superpoint_weights.display(),
        s.superpoint_sha256
    );
    Ok(())
}
