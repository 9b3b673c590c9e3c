//! The library entry point: build the room and its camera paths, render every frame in
//! parallel and write the chosen layout atomically.

use super::dataset::SynthDataset;
use super::error::{Result, SynthError};
use super::gt;
use super::layout::{
    Layout, NvmCamera, Staging, cambridge_name, cambridge_nvm_name, encode_png_depth,
    encode_png_rgb, format_cambridge_split, format_nvm, format_pose_txt, format_split_file,
    seven_scenes_names,
};
use super::trajectory::{DEFAULT_FRAMES, FrameSpec, Split};
use fileio::IoError;
use geometry::{Camera, Pose};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::path::PathBuf;

/// Default scene folder name.
pub const DEFAULT_SCENE_NAME: &str = "synthroom";

/// The scene the synth stage renders: its configuration (`[synth]` of a pipeline file,
/// the flags of `pl2map synth`), the only place its settings and defaults live.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, clap::Args)]
#[serde(default, deny_unknown_fields)]
pub struct SynthConfig {
    /// The test-sized scene: 24 training + 8 test frames (`frames` is then ignored).
    #[arg(long)]
    pub tiny: bool,
    /// Total frames (2/3 training).
    #[arg(long, default_value_t = SynthConfig::default().frames)]
    pub frames: usize,
    /// Seed of the room and the camera paths.
    #[arg(long, default_value_t = SynthConfig::default().seed)]
    pub seed: u64,
    /// RMS 3D error (cm) added to the written ground-truth labels; the exact ones go to
    /// `sfm_gt/exact.json` (see [`super::gt::noise`]), for the refine stage to remove.
    #[arg(long, default_value_t = SynthConfig::default().label_noise_cm)]
    pub label_noise_cm: f64,
    /// Layout of the written dataset.
    #[arg(long, default_value_t = SynthConfig::default().layout)]
    pub layout: Layout,
    /// Scene folder name inside the output folder.
    #[arg(long, default_value_t = SynthConfig::default().name)]
    pub name: String,
    /// Only the first N training sequences (None: all): the dataset as recorded so far.
    /// The frames kept are the same as in the full scene, so a later run with more
    /// sequences adds frames without changing the others (nightly retraining).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[arg(long)]
    pub train_sequences: Option<usize>,
    /// Also write the COLMAP and LIMAP ground truth of the training frames to
    /// `<scene>/sfm_gt/` (see [`super::gt`]).
    #[serde(skip_serializing_if = "is_true")]
    #[arg(long = "no-gt", action = clap::ArgAction::SetFalse, help = "Skip the ground truth (the COLMAP model and LIMAP folder under sfm_gt/)")]
    pub ground_truth: bool,
}

fn is_true(b: &bool) -> bool {
    *b
}

impl Default for SynthConfig {
    fn default() -> Self {
        SynthConfig {
            tiny: false,
            frames: DEFAULT_FRAMES,
            seed: 0,
            label_noise_cm: 0.0,
            layout: Layout::SevenScenes,
            name: DEFAULT_SCENE_NAME.into(),
            train_sequences: None,
            ground_truth: true,
        }
    }
}

impl SynthConfig {
    /// Refuses settings that cannot make a scene (before anything is written).
    pub fn validate(&self) -> Result<()> {
        if self.name.is_empty() || self.name.contains(['/', '\\']) || self.name.starts_with('.') {
            return Err(SynthError::InvalidConfig(format!(
                "scene name {:?} must be a plain folder name",
                self.name
            )));
        }
        if !(self.label_noise_cm.is_finite() && self.label_noise_cm >= 0.0) {
            return Err(SynthError::InvalidConfig(format!(
                "label_noise_cm must be finite and >= 0, got {}",
                self.label_noise_cm
            )));
        }
        Ok(())
    }
}

impl SynthConfig {
    /// The planned scene and camera paths (nothing rendered).
    pub fn dataset(&self) -> Result<SynthDataset> {
        let mut dataset = SynthDataset::new(self.frames, self.seed, self.tiny)?;
        if let Some(n) = self.train_sequences {
            dataset.keep_train_sequences(n)?;
        }
        Ok(dataset)
    }
}

/// The colour image of a frame, relative to the scene folder, in `layout`.
pub fn color_name(layout: Layout, f: &FrameSpec) -> String {
    match layout {
        Layout::SevenScenes => seven_scenes_names(f.sequence, f.index).0,
        Layout::Cambridge => cambridge_name(f.sequence, f.index),
    }
}

/// Where and how [`generate`] writes (not part of the scene's configuration).
#[derive(Clone, Debug, PartialEq)]
pub struct WriteOptions {
    /// Output folder; the scene goes to `out/<name>`.
    pub out: PathBuf,
    /// Replace an existing `out/<name>`.
    pub overwrite: bool,
    /// Show a progress bar (hidden anyway when stderr is not a terminal or with
    /// `--quiet`).
    pub progress: bool,
}

impl WriteOptions {
    /// Writes into `out`, refusing an existing scene folder, with a progress bar.
    pub fn new(out: impl Into<PathBuf>) -> Self {
        WriteOptions {
            out: out.into(),
            overwrite: false,
            progress: true,
        }
    }
}

/// One written frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameInfo {
    /// Index into [`SynthDataset::frames`].
    pub index: usize,
    /// The image's name relative to the scene folder, as the layout's lists name it
    /// (`seq-01/frame-000000.color.png`, `seq1/frame00001.png`).
    pub name: String,
    pub split: Split,
    pub sequence: u32,
    pub frame_in_sequence: usize,
    pub camera: Camera,
    /// World-to-camera, exact (the files hold it to 8 significant digits, 7-Scenes, or
    /// 6 decimals, Cambridge).
    pub pose: Pose,
    pub color_path: PathBuf,
    /// 7-Scenes only.
    pub depth_path: Option<PathBuf>,
    /// 7-Scenes only.
    pub pose_path: Option<PathBuf>,
}

/// What [`generate`] wrote.
#[derive(Clone, Debug)]
pub struct SynthOutput {
    /// The scene folder `out/<scene_name>`.
    pub root: PathBuf,
    pub layout: Layout,
    pub dataset: SynthDataset,
    pub frames: Vec<FrameInfo>,
    /// Counts of the ground truth, when it was written.
    pub ground_truth: Option<gt::GtSummary>,
}

/// The tiny scene (default seed, with its ground truth) written to `out/<name>` without
/// a progress bar: what `pl2map synth OUT --tiny --quiet` writes, and the fixture of the
/// stages' tests.
pub fn generate_tiny(out: &std::path::Path) -> Result<SynthOutput> {
    generate(
        &SynthConfig {
            tiny: true,
            ..SynthConfig::default()
        },
        &WriteOptions {
            progress: false,
            ..WriteOptions::new(out)
        },
    )
}

/// Builds, renders and writes the synthetic dataset. Same config (seed included) =>
/// byte-identical files, whatever the number of rayon threads.
pub fn generate(cfg: &SynthConfig, write: &WriteOptions) -> Result<SynthOutput> {
    cfg.validate()?;
    let gt_cfg = gt::GtConfig {
        label_noise_cm: cfg.label_noise_cm,
        ..gt::GtConfig::default()
    };
    let gt_err =
        |e: gt::GtError| SynthError::from(IoError::new(gt::GT_DIR, std::io::Error::other(e)));
    if cfg.ground_truth {
        gt_cfg.validate().map_err(gt_err)?;
    }
    let dataset = cfg.dataset()?;
    let staging = Staging::new(&write.out, &cfg.name, write.overwrite)?;
    let root = staging.dest().to_path_buf();

    let mut seqs: BTreeSet<u32> = BTreeSet::new();
    for f in &dataset.frames {
        seqs.insert(f.sequence);
    }
    for s in &seqs {
        match cfg.layout {
            Layout::SevenScenes => staging.create_dir(&format!("seq-{s:02}"))?,
            Layout::Cambridge => staging.create_dir(&format!("seq{s}"))?,
        }
    }

    let bar = if write.progress {
        stage::progress_bar(dataset.len() as u64, "synth")
    } else {
        indicatif::ProgressBar::hidden()
    };

    let rendered: Vec<(FrameInfo, Option<gt::FrameObservations>)> = (0..dataset.len())
        .into_par_iter()
        .map(|i| {
            let f = dataset.frames[i];
            let r = dataset.render_frame(i)?;
            let info = match cfg.layout {
                Layout::SevenScenes => {
                    let (c, d, p) = seven_scenes_names(f.sequence, f.index);
                    let tmp = staging.path();
                    staging.write(&c, &encode_png_rgb(&r.rgb, &tmp.join(&c))?)?;
                    staging.write(&d, &encode_png_depth(&r.depth_mm(), &tmp.join(&d))?)?;
                    staging.write(
                        &p,
                        format_pose_txt(&f.pose.inverse().to_matrix()).as_bytes(),
                    )?;
                    FrameInfo {
                        index: i,
                        name: c.clone(),
                        split: f.split,
                        sequence: f.sequence,
                        frame_in_sequence: f.index,
                        camera: dataset.camera.clone(),
                        pose: f.pose,
                        color_path: root.join(&c),
                        depth_path: Some(root.join(&d)),
                        pose_path: Some(root.join(&p)),
                    }
                }
                Layout::Cambridge => {
                    let c = cambridge_name(f.sequence, f.index);
                    staging.write(&c, &encode_png_rgb(&r.rgb, &staging.path().join(&c))?)?;
                    FrameInfo {
                        index: i,
                        name: c.clone(),
                        split: f.split,
                        sequence: f.sequence,
                        frame_in_sequence: f.index,
                        camera: dataset.camera.clone(),
                        pose: f.pose,
                        color_path: root.join(&c),
                        depth_path: None,
                        pose_path: None,
                    }
                }
            };
            let obs = if cfg.ground_truth && f.split == Split::Train {
                Some(gt::observe_frame(&dataset, i, &r.rgb, &gt_cfg).map_err(gt_err)?)
            } else {
                None
            };
            bar.inc(1);
            Ok((info, obs))
        })
        .collect::<Result<Vec<_>>>()?;
    bar.finish_and_clear();
    let mut gt_images = Vec::new();
    let mut gt_obs = Vec::new();
    let mut frames = Vec::with_capacity(rendered.len());
    for (info, obs) in rendered {
        if let Some(o) = obs {
            gt_images.push(gt::GtImage {
                image_id: gt_images.len() as u32 + 1,
                frame: info.index,
                name: info.name.clone(),
            });
            gt_obs.push(o);
        }
        frames.push(info);
    }
    let ground_truth = if cfg.ground_truth {
        let labels = gt::build(&dataset, gt_images, gt_obs, &gt_cfg).map_err(gt_err)?;
        gt::write(staging.path(), &dataset, &labels, &gt_cfg).map_err(gt_err)?;
        Some(labels.summary())
    } else {
        None
    };

    match cfg.layout {
        Layout::SevenScenes => {
            staging.write(
                "TrainSplit.txt",
                format_split_file(&dataset.sequences(Split::Train)).as_bytes(),
            )?;
            staging.write(
                "TestSplit.txt",
                format_split_file(&dataset.sequences(Split::Test)).as_bytes(),
            )?;
        }
        Layout::Cambridge => {
            for (split, file) in [
                (Split::Train, "dataset_train.txt"),
                (Split::Test, "dataset_test.txt"),
            ] {
                let rows: Vec<(String, Pose)> = frames
                    .iter()
                    .filter(|f| f.split == split)
                    .map(|f| (f.name.clone(), f.pose))
                    .collect();
                staging.write(file, format_cambridge_split(&rows).as_bytes())?;
            }
            let focal = dataset.camera.mean_focal_length();
            let cams: Vec<NvmCamera> = frames
                .iter()
                .map(|f| NvmCamera {
                    name: cambridge_nvm_name(f.sequence, f.frame_in_sequence),
                    focal,
                    pose: f.pose,
                })
                .collect();
            staging.write("reconstruction.nvm", format_nvm(&cams, &[]).as_bytes())?;
        }
    }
    let root = staging.commit()?;
    Ok(SynthOutput {
        root,
        layout: cfg.layout,
        dataset,
        frames,
        ground_truth,
    })
}
