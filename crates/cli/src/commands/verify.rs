//! `pl2map lock PIPELINE.toml --out MANIFEST.toml` writes the lock file of a pipeline's
//! training set (inputs, config, shard hashes); `pl2map verify MANIFEST.toml` rebuilds
//! it in a temporary folder and compares every hash, failing on any difference.

use anyhow::Context;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct VerifyArgs {
    /// Lock file (manifests/*.toml).
    pub manifest: PathBuf,
    /// Rebuild here (kept) instead of in a temporary folder.
    #[arg(long)]
    pub work: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
pub struct LockArgs {
    /// Pipeline file with a [synth] section.
    pub pipeline: PathBuf,
    /// Lock file to write.
    #[arg(long)]
    pub out: PathBuf,
}

pub fn verify(args: VerifyArgs, quiet: bool) -> anyhow::Result<()> {
    let report = pipeline::verify(&args.manifest, args.work.as_deref(), !quiet)
        .with_context(|| format!("rebuilding {}", args.manifest.display()))?;
    crate::out!("{}", report.table());
    report.check()?;
    crate::outln!(
        "{}: all {} hashes match",
        args.manifest.display(),
        report.rows.len()
    );
    Ok(())
}

pub fn lock(args: LockArgs, quiet: bool) -> anyhow::Result<()> {
    let p = pipeline::Pipeline::load(&args.pipeline)?;
    let options = pipeline::RunOptions {
        until: Some(pipeline::StageName::Shard),
        progress: !quiet,
        ..Default::default()
    };
    let report = pipeline::run(&p, &options)
        .with_context(|| format!("running {}", args.pipeline.display()))?;
    crate::out!("{}", report.table());
    let lock = pipeline::Lock::collect(&p)?;
    lock.write(&args.out, &args.pipeline.display().to_string())?;
    crate::outln!(
        "{}: {} inputs, {} outputs, {} shards",
        args.out.display(),
        lock.inputs.len(),
        lock.outputs.len(),
        lock.shards.len()
    );
    Ok(())
}
