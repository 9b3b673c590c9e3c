//! `pl2map features`: keypoints, scores and descriptors of a folder or list of images in
//! hloc's feature-file layout (HDF5), so that hloc's matchers and h5py read them
//! (docs/formats.md, "Feature files").

use anyhow::{Context, bail};
use features::{FrontEndConfig, FrontEndKind};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// sift or superpoint.
    #[arg(long, default_value_t = FrontEndKind::Sift)]
    front_end: FrontEndKind,
    /// SuperPoint weights (`superpoint_v1.pth`); default: PL2MAP_SUPERPOINT_WEIGHTS.
    #[arg(long)]
    weights: Option<PathBuf>,
    /// A folder (searched recursively for .png / .jpg; names relative to it) or a text
    /// file listing one image per line (relative to the list's folder; the names as
    /// listed).
    #[arg(long)]
    images: PathBuf,
    /// The HDF5 file to write (replaced atomically).
    #[arg(long)]
    out: PathBuf,
    /// Keypoints per image.
    #[arg(long, default_value_t = 2048)]
    max_keypoints: usize,
    /// Also write each image's dense score map (`dense_scores`, H x W) and dense
    /// descriptor map (`dense_descriptors`, D x H/8 x W/8); SuperPoint only.
    #[arg(long)]
    dense: bool,
}

/// (name, path) of every image.
fn image_list(images: &Path) -> anyhow::Result<Vec<(String, PathBuf)>> {
    if images.is_dir() {
        let listing = tables::image_file::list(images)
            .with_context(|| format!("listing {}", images.display()))?;
        for line in &listing.skipped {
            tracing::warn!("{line}");
        }
        // 7-Scenes keeps its depth maps (`*.depth.png`) next to the colour images.
        return listing
            .files
            .into_iter()
            .filter(|p| !p.to_string_lossy().contains(".depth."))
            .map(|p| {
                let rel = p.strip_prefix(images).unwrap_or(&p);
                let name = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect::<Vec<_>>()
                    .join("/");
                Ok((name, p))
            })
            .collect();
    }
    let text =
        std::fs::read_to_string(images).with_context(|| format!("reading {}", images.display()))?;
    let base = images.parent().unwrap_or(Path::new("."));
    Ok(text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| (l.to_string(), base.join(l)))
        .collect())
}

/// The group of `name`, creating the groups of its `/`-separated parts as h5py does.
fn group_for(file: &hdf5::File, name: &str) -> anyhow::Result<hdf5::Group> {
    let mut g: hdf5::Group = (**file).clone();
    for part in name.split('/').filter(|p| !p.is_empty()) {
        g = if g.link_exists(part) {
            g.group(part)?
        } else {
            g.create_group(part)?
        };
    }
    Ok(g)
}

fn write<T: hdf5::H5Type>(
    g: &hdf5::Group,
    name: &str,
    shape: &[usize],
    v: &[T],
) -> anyhow::Result<()> {
    let ds = g.new_dataset::<T>().shape(shape.to_vec()).create(name)?;
    ds.write_raw(v)?;
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let mut cfg = FrontEndConfig {
        kind: args.front_end,
        ..FrontEndConfig::query()
    };
    cfg.set_max_keypoints(args.max_keypoints);
    if args.weights.is_some() {
        cfg.superpoint.weights = args.weights.clone();
    }
    if args.dense && args.front_end != FrontEndKind::Superpoint {
        bail!("--dense writes SuperPoint's dense maps: it needs --front-end superpoint");
    }
    let images = image_list(&args.images)?;
    if images.is_empty() {
        bail!("no images in {}", args.images.display());
    }
    // The SuperPoint front-end itself for the dense maps, the trait object otherwise.
    let sp = match args.front_end {
        FrontEndKind::Superpoint => Some(superpoint::SuperPointFrontEnd::from_config(&cfg)?),
        FrontEndKind::Sift => None,
    };
    let fe: Box<dyn features::FrontEnd> = match sp {
        Some(_) => Box::new(superpoint::SuperPointFrontEnd::from_config(&cfg)?),
        None => Box::new(features::SiftFrontEnd::new(cfg.clone())?),
    };
    let dir = args
        .out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut builder = tempfile::Builder::new();
    builder.prefix(".features-").suffix(".h5.tmp");
    // tempfile creates 0600 files; the feature file is an ordinary output (0666 minus
    // umask), as stage::AtomicFile makes them (crates/stage/src/atomic.rs).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let tmp = builder
        .tempfile_in(dir)
        .with_context(|| format!("creating a temporary file in {}", dir.display()))?;
    // Images that cannot be read are left out and named; the others are written and
    // the exit status is non-zero (as `pl2map localize` does).
    let mut unreadable: Vec<String> = Vec::new();
    {
        let file = hdf5::File::create(tmp.path())
            .with_context(|| format!("creating {}", tmp.path().display()))?;
        for (name, path) in &images {
            let gray = match read_gray(path) {
                Ok(g) => g,
                Err(reason) => {
                    tracing::error!("{reason}");
                    unreadable.push(reason);
                    continue;
                }
            };
            let det = fe
                .detect(&gray)
                .with_context(|| format!("{}: front-end", path.display()))?;
            let g = group_for(&file, name).with_context(|| format!("group {name}"))?;
            let n = det.keypoints.len();
            // hloc's keypoints: pixel indices (COLMAP - 0.5).
            let kp: Vec<f32> = det
                .keypoints
                .iter()
                .flat_map(|p| [(p[0] - 0.5) as f32, (p[1] - 0.5) as f32])
                .collect();
            write(&g, "keypoints", &[n, 2], &kp)?;
            write(&g, "scores", &[n], &det.scores)?;
            let d = det.dim;
            let mut dn = vec![0f32; d * n];
            for (i, row) in det.descriptors.chunks_exact(d).enumerate() {
                for (k, v) in row.iter().enumerate() {
                    dn[k * n + i] = *v;
                }
            }
            write(&g, "descriptors", &[d, n], &dn)?;
            write(
                &g,
                "image_size",
                &[2],
                &[gray.width() as i64, gray.height() as i64],
            )?;
            if args.dense
                && let Some(sp) = &sp
            {
                let (maps, _) = sp.dense(&gray)?;
                write(
                    &g,
                    "dense_scores",
                    &[maps.score_height, maps.score_width],
                    &maps.scores,
                )?;
                write(
                    &g,
                    "dense_descriptors",
                    &[d, maps.cell_height, maps.cell_width],
                    &maps.descriptors,
                )?;
            }
        }
        file.flush()?;
    }
    if unreadable.len() == images.len() {
        // Nothing to write: no file under the final name (the temp file is removed).
        bail!(
            "none of the {} images could be read; {} is not written:\n{}",
            images.len(),
            args.out.display(),
            unreadable.join("\n")
        );
    }
    tmp.persist(&args.out)
        .with_context(|| format!("writing {}", args.out.display()))?;
    crate::outln!(
        "{}: {} features of {} images",
        args.out.display(),
        args.front_end,
        images.len() - unreadable.len()
    );
    if !unreadable.is_empty() {
        bail!(
            "{} of {} images could not be read and are not in {}:\n{}",
            unreadable.len(),
            images.len(),
            args.out.display(),
            unreadable.join("\n")
        );
    }
    Ok(())
}

/// An image file as grey, read within bounds (no device or FIFO, the header and the
/// pixel limit first) and after the structural check ingest makes (a JPEG or PNG cut
/// short is refused with the byte offset, not decoded with its missing part filled in).
fn read_gray(path: &Path) -> Result<image::GrayImage, String> {
    let bytes = features::image_file::read_image(path).map_err(|e| e.to_string())?;
    tables::image_file::check_complete(&bytes).map_err(|r| format!("{}: {r}", path.display()))?;
    features::decode_gray(&bytes).map_err(|e| format!("{}: {e}", path.display()))
}
