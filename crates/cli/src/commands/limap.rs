use std::path::PathBuf;

use anyhow::Context;
use clap::Subcommand;

#[derive(Subcommand)]
pub enum Command {
    /// Summarise a LIMAP output folder and run every consistency check. Exits with an
    /// error when a check fails (after printing the summary).
    Info {
        /// The LIMAP output folder (image_list.txt, finaltracks/, alltracks.txt, ...).
        dir: PathBuf,
        /// The segments folder used for triangulation. Without it, the only folder among
        /// DIR/line_detections/*/segments and DIR/segments is used.
        #[arg(long)]
        segments: Option<PathBuf>,
        /// Track folder inside DIR (LIMAP's output_folder).
        #[arg(long, default_value = limap::dir::DEFAULT_TRACKS_FOLDER)]
        tracks_folder: PathBuf,
        /// Also read track files of old LIMAP versions (no line2d_list).
        #[arg(long)]
        allow_legacy_tracks: bool,
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
    },
}

pub fn run(cmd: Command) -> anyhow::Result<()> {
    match cmd {
        Command::Info {
            dir,
            segments,
            tracks_folder,
            allow_legacy_tracks,
            json,
        } => {
            let options = limap::LimapDirOptions {
                segments,
                tracks_folder: Some(tracks_folder),
                allow_legacy_tracks,
            };
            let limap_dir = limap::LimapDir::open_unchecked(&dir, &options)
                .with_context(|| format!("reading LIMAP folder {}", dir.display()))?;
            let report = limap_dir.check();
            let summary = limap::Summary::new(&limap_dir, &report);
            if json {
                crate::outln!("{}", serde_json::to_string_pretty(&summary)?);
            } else {
                crate::out!("{summary}");
            }
            let errors = report.errors().count();
            if errors > 0 {
                anyhow::bail!(
                    "{}: {errors} consistency error(s); see the checks above",
                    dir.display()
                );
            }
            Ok(())
        }
    }
}
