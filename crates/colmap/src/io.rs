//! Reading and writing model directories.
//!
//! Reading follows COLMAP's `Reconstruction::Read`: the binary files when cameras,
//! images and points3D all exist as `.bin`, else the text files. Writing produces all
//! five files, each first to a temporary file in the same directory; the renames happen
//! only after all five are complete, so a failed or killed write never leaves a
//! truncated model file under its final name.

use crate::binary;
use crate::error::{ColmapError, Table};
use crate::model::Reconstruction;
use crate::text::{self, TextFiles};
use fileio::{IoError, IoResultExt};
use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Binary,
    Text,
}

impl Format {
    fn ext(self) -> &'static str {
        match self {
            Format::Binary => "bin",
            Format::Text => "txt",
        }
    }
}

const REQUIRED: [Table; 3] = [Table::Cameras, Table::Images, Table::Points3D];
const ALL: [Table; 5] = [
    Table::Cameras,
    Table::Images,
    Table::Points3D,
    Table::Rigs,
    Table::Frames,
];

fn path_of(dir: &Path, table: Table, format: Format) -> PathBuf {
    dir.join(format!("{}.{}", table.stem(), format.ext()))
}

fn has_all(dir: &Path, format: Format) -> bool {
    REQUIRED.iter().all(|&t| path_of(dir, t, format).is_file())
}

/// Which files `read` would use.
pub fn detect_format(dir: &Path) -> crate::Result<Format> {
    if has_all(dir, Format::Binary) {
        Ok(Format::Binary)
    } else if has_all(dir, Format::Text) {
        Ok(Format::Text)
    } else {
        Err(ColmapError::MissingModel {
            dir: dir.to_path_buf(),
        })
    }
}

/// Reads a model directory (binary if complete, else text).
pub fn read(dir: &Path) -> crate::Result<Reconstruction> {
    match detect_format(dir)? {
        Format::Binary => read_binary(dir),
        Format::Text => read_text(dir),
    }
}

fn load(path: &Path) -> crate::Result<Vec<u8>> {
    Ok(fs::read(path).at(path)?)
}

fn load_optional(path: &Path) -> crate::Result<Option<Vec<u8>>> {
    match fs::read(path) {
        Ok(b) => Ok(Some(b)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(IoError::new(path, e).into()),
    }
}

pub fn read_binary(dir: &Path) -> crate::Result<Reconstruction> {
    let p = |t| path_of(dir, t, Format::Binary);
    // points3D.bin is read and parsed on a second thread while this one does the rest
    // (images.bin is the other big file): file I/O and parsing overlap.
    std::thread::scope(|s| {
        let points = s.spawn(|| {
            let path = p(Table::Points3D);
            binary::parse_points3d(&path, &load(&path)?)
        });
        let small = (|| -> crate::Result<_> {
            let path = p(Table::Cameras);
            let cameras = binary::parse_cameras(&path, &load(&path)?)?;
            let path = p(Table::Rigs);
            let rigs = match load_optional(&path)? {
                Some(b) => binary::parse_rigs(&path, &b)?,
                None => Vec::new(),
            };
            let path = p(Table::Frames);
            let frames = match load_optional(&path)? {
                Some(b) => binary::parse_frames(&path, &b)?,
                None => Vec::new(),
            };
            let path = p(Table::Images);
            let images = binary::parse_images(&path, &load(&path)?)?;
            Ok((cameras, rigs, frames, images))
        })();
        let points = points
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        let (cameras, rigs, frames, images) = small?;
        binary::assemble(dir, cameras, images, points?, rigs, frames)
    })
}

pub fn read_text(dir: &Path) -> crate::Result<Reconstruction> {
    let p = |t| path_of(dir, t, Format::Text);
    let cameras = load(&p(Table::Cameras))?;
    let images = load(&p(Table::Images))?;
    let points3d = load(&p(Table::Points3D))?;
    let rigs = load_optional(&p(Table::Rigs))?;
    let frames = load_optional(&p(Table::Frames))?;
    let decode_opt = |t: Table, b: &Option<Vec<u8>>| -> crate::Result<Option<String>> {
        b.as_deref()
            .map(|b| text::decode(&p(t), b).map(str::to_owned))
            .transpose()
    };
    let rigs = decode_opt(Table::Rigs, &rigs)?;
    let frames = decode_opt(Table::Frames, &frames)?;
    text::parse_model(
        dir,
        &TextFiles {
            cameras: text::decode(&p(Table::Cameras), &cameras)?,
            images: text::decode(&p(Table::Images), &images)?,
            points3d: text::decode(&p(Table::Points3D), &points3d)?,
            rigs: rigs.as_deref(),
            frames: frames.as_deref(),
        },
    )
}

pub fn write_binary(rec: &Reconstruction, dir: &Path) -> crate::Result<()> {
    write(rec, dir, Format::Binary)
}

pub fn write_text(rec: &Reconstruction, dir: &Path) -> crate::Result<()> {
    write(rec, dir, Format::Text)
}

/// Writes all five files (creating `dir` if needed).
pub fn write(rec: &Reconstruction, dir: &Path, format: Format) -> crate::Result<()> {
    fs::create_dir_all(dir).at(dir)?;
    let mut temps: Vec<(PathBuf, PathBuf)> = Vec::with_capacity(ALL.len());
    let result = (|| {
        for table in ALL {
            let target = path_of(dir, table, format);
            let temp = dir.join(format!(
                ".{}.{}.tmp-{}",
                table.stem(),
                format.ext(),
                std::process::id()
            ));
            temps.push((temp.clone(), target.clone()));
            write_one(rec, table, format, &temp, &target)?;
        }
        for (temp, target) in &temps {
            fs::rename(temp, target).at(target)?;
        }
        Ok(())
    })();
    if result.is_err() {
        for (temp, _) in &temps {
            let _ = fs::remove_file(temp);
        }
    }
    result
}

fn write_one(
    rec: &Reconstruction,
    table: Table,
    format: Format,
    temp: &Path,
    target: &Path,
) -> crate::Result<()> {
    let file = fs::File::create(temp).at(temp)?;
    let mut w = BufWriter::with_capacity(1 << 20, file);
    // Errors name the final file: that is the one the user asked for.
    match (format, table) {
        (Format::Binary, Table::Cameras) => binary::write_cameras(target, &mut w, &rec.cameras),
        (Format::Binary, Table::Images) => binary::write_images(target, &mut w, &rec.images),
        (Format::Binary, Table::Points3D) => binary::write_points3d(target, &mut w, &rec.points3d),
        (Format::Binary, Table::Rigs) => binary::write_rigs(target, &mut w, &rec.rigs),
        (Format::Binary, Table::Frames) => binary::write_frames(target, &mut w, &rec.frames),
        (Format::Text, Table::Cameras) => text::write_cameras(target, &mut w, rec),
        (Format::Text, Table::Images) => text::write_images(target, &mut w, rec),
        (Format::Text, Table::Points3D) => text::write_points3d(target, &mut w, rec),
        (Format::Text, Table::Rigs) => text::write_rigs(target, &mut w, rec),
        (Format::Text, Table::Frames) => text::write_frames(target, &mut w, rec),
    }?;
    let file = w.into_inner().map_err(|e| e.into_error()).at(target)?;
    file.sync_all().at(target)?;
    Ok(())
}

/// Encodes one table in memory (tests, tools that ship files elsewhere).
pub fn encode(rec: &Reconstruction, table: Table, format: Format) -> crate::Result<Vec<u8>> {
    let name = PathBuf::from(format!("{}.{}", table.stem(), format.ext()));
    let mut out = Vec::new();
    let w = &mut out;
    match (format, table) {
        (Format::Binary, Table::Cameras) => binary::write_cameras(&name, w, &rec.cameras),
        (Format::Binary, Table::Images) => binary::write_images(&name, w, &rec.images),
        (Format::Binary, Table::Points3D) => binary::write_points3d(&name, w, &rec.points3d),
        (Format::Binary, Table::Rigs) => binary::write_rigs(&name, w, &rec.rigs),
        (Format::Binary, Table::Frames) => binary::write_frames(&name, w, &rec.frames),
        (Format::Text, Table::Cameras) => text::write_cameras(&name, w, rec),
        (Format::Text, Table::Images) => text::write_images(&name, w, rec),
        (Format::Text, Table::Points3D) => text::write_points3d(&name, w, rec),
        (Format::Text, Table::Rigs) => text::write_rigs(&name, w, rec),
        (Format::Text, Table::Frames) => text::write_frames(&name, w, rec),
    }?;
    let _ = w.flush();
    Ok(out)
}

impl Reconstruction {
    pub fn read(dir: &Path) -> crate::Result<Self> {
        read(dir)
    }
    pub fn read_binary(dir: &Path) -> crate::Result<Self> {
        read_binary(dir)
    }
    pub fn read_text(dir: &Path) -> crate::Result<Self> {
        read_text(dir)
    }
    pub fn write_binary(&self, dir: &Path) -> crate::Result<()> {
        write_binary(self, dir)
    }
    pub fn write_text(&self, dir: &Path) -> crate::Result<()> {
        write_text(self, dir)
    }
}
