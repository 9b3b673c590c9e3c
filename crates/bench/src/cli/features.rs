use anyhow::{Context, bail};
use features::FrontEndConfig;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Folder searched recursively for .png / .jpg images (default: the 7-Scenes
    /// frames of the sample data, README.md "Tests", when present).
    #[arg(long)]
    images: Option<PathBuf>,
    /// Use at most this many images.
    #[arg(long, default_value_t = 24)]
    limit: usize,
    /// Keypoints per image (2048 = the query setting).
    #[arg(long, default_value_t = 2048)]
    max_keypoints: usize,
    /// Also time SuperPoint (forward + keypoints + descriptor sampling per image, on
    /// `--superpoint-threads` threads) with these weights.
    #[arg(long)]
    superpoint_weights: Option<PathBuf>,
    /// Threads of the SuperPoint timing.
    #[arg(long, default_value_t = 2)]
    superpoint_threads: usize,
    /// A Python with torch: times the PyTorch SuperPoint of the tests
    /// (crates/superpoint/tests/superpoint_torch.py) with the same weights and threads.
    #[arg(long)]
    torch_python: Option<PathBuf>,
}

/// Median seconds per image of SuperPoint's forward + keypoints + descriptors at them.
fn superpoint_seconds(
    images: &[image::GrayImage],
    weights: &Path,
    threads: usize,
) -> anyhow::Result<f64> {
    use features::FrontEnd;
    let cfg = FrontEndConfig {
        kind: features::FrontEndKind::Superpoint,
        superpoint: features::SuperPointConfig {
            weights: Some(weights.to_path_buf()),
            ..Default::default()
        },
        ..FrontEndConfig::query()
    };
    let fe = superpoint::SuperPointFrontEnd::from_config(&cfg)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    pool.install(|| {
        fe.detect(&images[0])?; // warm-up
        let mut t = Vec::new();
        for img in images {
            let s = std::time::Instant::now();
            fe.detect(img)?;
            t.push(s.elapsed().as_secs_f64());
        }
        t.sort_by(f64::total_cmp);
        Ok(t[t.len() / 2])
    })
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let dir = match args.images {
        Some(d) => d,
        None => {
            // The sample data as the tests find it: PL2MAP_SAMPLE_DATA (which `cargo run`
            // sets to README.md's default location, .cargo/config.toml).
            let d = std::env::var_os("PL2MAP_SAMPLE_DATA")
                .map(|root| PathBuf::from(root).join("7scenes-stairs-mini"))
                .filter(|d| d.is_dir());
            match d {
                Some(d) => d,
                None => bail!(
                    "no --images given and no 7scenes-stairs-mini under PL2MAP_SAMPLE_DATA; try `pl2map synth OUT` and pass --images OUT"
                ),
            }
        }
    };
    // 7-Scenes keeps its depth maps (`*.depth.png`) next to the colour images.
    let mut paths: Vec<PathBuf> = tables::image_file::list(&dir)
        .with_context(|| format!("listing {}", dir.display()))?
        .files
        .into_iter()
        .filter(|p| !p.to_string_lossy().contains(".depth."))
        .collect();
    paths.truncate(args.limit);
    if paths.is_empty() {
        bail!("no images under {}", dir.display());
    }
    let images = paths
        .iter()
        .map(|p| features::load_gray(p))
        .collect::<Result<Vec<_>, _>>()?;
    let (w, h) = images[0].dimensions();
    let mut cfg = FrontEndConfig::query();
    cfg.sift.max_keypoints = args.max_keypoints;
    let steps = crate::features::step_times(&images, &cfg)?;
    let t1 = crate::features::throughput(&images, &cfg, 1)?;
    let t2 = crate::features::throughput(&images, &cfg, 2)?;
    stage::outln!(
        "front-end benchmark: {} images of {w}x{h} from {}",
        images.len(),
        dir.display()
    );
    stage::outln!(
        "mean {:.0} keypoints, {:.0} segments per image (T = {})",
        steps.mean_keypoints,
        steps.mean_segments,
        cfg.samples_per_line
    );
    stage::outln!();
    stage::outln!("| step                                   | ms / image |");
    stage::outln!("|----------------------------------------|-----------:|");
    stage::outln!(
        "| SIFT detect (top {:>4})                 | {:>10.1} |",
        cfg.sift.max_keypoints,
        steps.sift_detect_ms
    );
    stage::outln!(
        "| SIFT describe at keypoints             | {:>10.1} |",
        steps.sift_describe_ms
    );
    stage::outln!(
        "| LSD                                    | {:>10.1} |",
        steps.lsd_ms
    );
    stage::outln!(
        "| line sampling + descriptors            | {:>10.1} |",
        steps.line_sampling_ms
    );
    stage::outln!();
    stage::outln!("| threads | images/s |");
    stage::outln!("|--------:|---------:|");
    stage::outln!("|       1 | {t1:>8.2} |");
    stage::outln!("|       2 | {t2:>8.2} |");
    stage::outln!("speed-up 2 vs 1 threads: {:.2}x", t2 / t1);
    if let Some(weights) = &args.superpoint_weights {
        let ours = superpoint_seconds(&images, weights, args.superpoint_threads)?;
        stage::outln!();
        stage::outln!(
            "SuperPoint forward + keypoints + descriptors, {w}x{h}, {} threads:",
            args.superpoint_threads
        );
        stage::outln!("| implementation | ms / image |");
        stage::outln!("|----------------|-----------:|");
        stage::outln!("| burn (Flex)    | {:>10.1} |", ours * 1e3);
        if let Some(py) = &args.torch_python {
            let script = concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../superpoint/tests/superpoint_torch.py"
            );
            let out = std::process::Command::new(py)
                .arg(script)
                .arg("bench")
                .arg(weights)
                .args([w.to_string(), h.to_string(), images.len().to_string()])
                .arg(args.superpoint_threads.to_string())
                .output()
                .with_context(|| format!("running {}", py.display()))?;
            if !out.status.success() {
                bail!("{script}: {}", String::from_utf8_lossy(&out.stderr).trim());
            }
            let v: serde_json::Value = serde_json::from_slice(&out.stdout)?;
            let theirs = v["median_s"].as_f64().unwrap_or(f64::NAN);
            stage::outln!(
                "| PyTorch {:<6} | {:>10.1} |",
                v["torch"]
                    .as_str()
                    .unwrap_or("?")
                    .split('+')
                    .next()
                    .unwrap_or("?"),
                theirs * 1e3
            );
            stage::outln!("burn / PyTorch: {:.2}x", ours / theirs);
        }
    }
    Ok(())
}
