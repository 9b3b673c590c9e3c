//! Writers of the two dataset layouts and their text formats.
//!
//! 7-Scenes: `<scene>/{TrainSplit.txt, TestSplit.txt}` (lines `sequenceN`, CRLF) and
//! `<scene>/seq-0N/frame-XXXXXX.{color.png, depth.png, pose.txt}`: 8-bit RGB PNG, 16-bit
//! grey PNG in millimetres (65535 = no depth), camera-to-world 4 x 4 matrix written like
//! the original files (`%15.7e` fields after a space, tab-separated, a trailing tab, CRLF,
//! three-digit exponents as the Windows C runtime prints them).
//!
//! Cambridge Landmarks: `<scene>/seqN/frameXXXXX.png` (1-based), `dataset_train.txt` and
//! `dataset_test.txt` (three header lines, then `name X Y Z W P Q R` with the camera
//! centre and the w-first world-to-camera quaternion), `reconstruction.nvm` (NVM_V3 with
//! every image, named `.jpg` like the original, although the files are `.png`).
//!
//! Everything is written into a staging folder next to the destination, renamed into
//! place in one step at the end; a killed run leaves only a `.partial` folder.

use super::error::{Result, SynthError};
use fileio::{IoError, IoResultExt};
use geometry::Pose;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{ExtendedColorType, ImageBuffer, ImageEncoder, Luma, RgbImage};
use nalgebra::Matrix4;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Which dataset layout to write.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    serde::Serialize,
    serde::Deserialize,
    strum::Display,
    strum::EnumString,
    strum::VariantNames,
)]
#[serde(rename_all = "lowercase")]
#[strum(
    serialize_all = "lowercase",
    parse_err_ty = String,
    parse_err_fn = unknown_layout
)]
pub enum Layout {
    // No case rule spells a leading digit: named by hand, on both sides. The command
    // line also takes `7-scenes`.
    #[serde(rename = "7scenes")]
    #[strum(to_string = "7scenes", serialize = "7-scenes")]
    SevenScenes,
    Cambridge,
}

/// The parse error, naming the accepted layouts.
fn unknown_layout(s: &str) -> String {
    use strum::VariantNames;
    format!(
        "unknown layout {s:?}: expected {}",
        Layout::VARIANTS.join(" or ")
    )
}

/// `x` as C's `printf("%.{prec}e")` on Windows: mantissa, `e`, sign, three-digit exponent.
pub fn format_c_exp(x: f64, prec: usize) -> String {
    // -0.0 prints as 0 in the original files' last row; normalise it.
    let x = if x == 0.0 { 0.0 } else { x };
    let s = format!("{x:.prec$e}");
    match s.split_once('e') {
        Some((mant, exp)) => {
            let (sign, digits) = match exp.strip_prefix('-') {
                Some(d) => ('-', d),
                None => ('+', exp),
            };
            format!("{mant}e{sign}{digits:0>3}")
        }
        None => s, // inf / NaN: never written for a valid pose
    }
}

/// A 4 x 4 matrix in the 7-Scenes `pose.txt` format.
pub fn format_pose_txt(m: &Matrix4<f64>) -> String {
    let mut out = String::with_capacity(4 * 70);
    for r in 0..4 {
        for c in 0..4 {
            let _ = write!(out, " {:>15}\t", format_c_exp(m[(r, c)], 7));
        }
        out.push_str("\r\n");
    }
    out
}

/// 7-Scenes split file: `sequenceN` lines, CRLF.
pub fn format_split_file(numbers: &[u32]) -> String {
    numbers.iter().map(|n| format!("sequence{n}\r\n")).collect()
}

/// Relative paths of a 7-Scenes frame: (colour, depth, pose).
pub fn seven_scenes_names(sequence: u32, index: usize) -> (String, String, String) {
    let stem = format!("seq-{sequence:02}/frame-{index:06}");
    (
        format!("{stem}.color.png"),
        format!("{stem}.depth.png"),
        format!("{stem}.pose.txt"),
    )
}

/// Relative path of a Cambridge frame (1-based numbering as in the original).
pub fn cambridge_name(sequence: u32, index: usize) -> String {
    format!("seq{sequence}/frame{:05}.png", index + 1)
}

/// The NVM name of a Cambridge frame: `.jpg`, like the original reconstruction files.
pub fn cambridge_nvm_name(sequence: u32, index: usize) -> String {
    format!("seq{sequence}/frame{:05}.jpg", index + 1)
}

fn clean(x: f64) -> f64 {
    if x == 0.0 { 0.0 } else { x }
}

/// `dataset_train.txt` / `dataset_test.txt`: header, then `name X Y Z W P Q R` (centre,
/// w-first world-to-camera quaternion), 6 decimals like the original files.
pub fn format_cambridge_split(rows: &[(String, Pose)]) -> String {
    let mut out =
        String::from("Visual Landmark Dataset V1\nImageFile, Camera Position [X Y Z W P Q R]\n\n");
    for (name, pose) in rows {
        let c = pose.centre();
        let q = pose.qvec();
        let _ = writeln!(
            out,
            "{name} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6}",
            clean(c.x),
            clean(c.y),
            clean(c.z),
            clean(q[0]),
            clean(q[1]),
            clean(q[2]),
            clean(q[3])
        );
    }
    out
}

/// An NVM camera: image name, focal length in pixels, world-to-camera pose (the file
/// stores the w-first world-to-camera quaternion and the camera centre).
#[derive(Clone, Debug, PartialEq)]
pub struct NvmCamera {
    pub name: String,
    pub focal: f64,
    pub pose: Pose,
}

/// One observation of an NVM point: camera index, feature index, image position (written
/// as given; VisualSfM measures from the principal point, COLMAP's exporter from the corner).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NvmMeasurement {
    pub camera: u32,
    pub feature: u32,
    pub x: f64,
    pub y: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct NvmPoint {
    pub xyz: [f64; 3],
    pub rgb: [u8; 3],
    pub measurements: Vec<NvmMeasurement>,
}

/// An NVM_V3 file: cameras `name f qw qx qy qz Cx Cy Cz 0 0` (no radial distortion),
/// then points `X Y Z R G B n (cam feat x y)*n`. Floats in shortest round-trip form.
pub fn format_nvm(cameras: &[NvmCamera], points: &[NvmPoint]) -> String {
    let mut out = format!("NVM_V3\n\n{}\n", cameras.len());
    for cam in cameras {
        let q = cam.pose.qvec();
        let c = cam.pose.centre();
        let _ = writeln!(
            out,
            "{} {} {} {} {} {} {} {} {} 0 0",
            cam.name,
            clean(cam.focal),
            clean(q[0]),
            clean(q[1]),
            clean(q[2]),
            clean(q[3]),
            clean(c.x),
            clean(c.y),
            clean(c.z)
        );
    }
    let _ = write!(out, "\n{}\n", points.len());
    for p in points {
        let _ = write!(
            out,
            "{} {} {} {} {} {} {}",
            clean(p.xyz[0]),
            clean(p.xyz[1]),
            clean(p.xyz[2]),
            p.rgb[0],
            p.rgb[1],
            p.rgb[2],
            p.measurements.len()
        );
        for m in &p.measurements {
            let _ = write!(
                out,
                " {} {} {} {}",
                m.camera,
                m.feature,
                clean(m.x),
                clean(m.y)
            );
        }
        out.push('\n');
    }
    out
}

/// PNG bytes of an RGB image (fixed encoder settings: identical bytes for identical pixels).
pub fn encode_png_rgb(img: &RgbImage, path: &Path) -> Result<Vec<u8>> {
    let mut buf = Vec::new();
    PngEncoder::new_with_quality(&mut buf, CompressionType::Fast, FilterType::Adaptive)
        .write_image(
            img.as_raw(),
            img.width(),
            img.height(),
            ExtendedColorType::Rgb8,
        )
        .map_err(|source| SynthError::Encode {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(buf)
}

/// PNG bytes of a 16-bit grey image.
pub fn encode_png_depth(img: &ImageBuffer<Luma<u16>, Vec<u16>>, path: &Path) -> Result<Vec<u8>> {
    // The encoder takes 16-bit samples in native byte order and writes them big-endian.
    let bytes: Vec<u8> = img.as_raw().iter().flat_map(|v| v.to_ne_bytes()).collect();
    let mut buf = Vec::new();
    PngEncoder::new_with_quality(&mut buf, CompressionType::Fast, FilterType::Adaptive)
        .write_image(&bytes, img.width(), img.height(), ExtendedColorType::L16)
        .map_err(|source| SynthError::Encode {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(buf)
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename.
pub fn write_file_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    std::fs::write(&tmp, bytes).at(&tmp)?;
    Ok(std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        IoError::new(path, e)
    })?)
}

/// A staging folder `OUT/.<name>.partial-<pid>` that becomes `OUT/<name>` on commit and
/// is removed if dropped uncommitted.
pub struct Staging {
    tmp: PathBuf,
    dest: PathBuf,
    overwrite: bool,
    committed: bool,
}

impl Staging {
    pub fn new(out: &Path, name: &str, overwrite: bool) -> Result<Self> {
        let dest = out.join(name);
        if dest.exists() && !overwrite {
            return Err(SynthError::OutputExists(dest));
        }
        std::fs::create_dir_all(out).at(out)?;
        let tmp = out.join(format!(".{name}.partial-{}", std::process::id()));
        if tmp.exists() {
            std::fs::remove_dir_all(&tmp).at(&tmp)?;
        }
        std::fs::create_dir(&tmp).at(&tmp)?;
        Ok(Staging {
            tmp,
            dest,
            overwrite,
            committed: false,
        })
    }

    /// Where files go until the commit.
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// The final folder.
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Creates a sub-folder of the staging folder.
    pub fn create_dir(&self, rel: &str) -> Result<()> {
        let p = self.tmp.join(rel);
        Ok(std::fs::create_dir_all(&p).at(&p)?)
    }

    /// Writes a file (relative path) into the staging folder.
    pub fn write(&self, rel: &str, bytes: &[u8]) -> Result<()> {
        let p = self.tmp.join(rel);
        Ok(std::fs::write(&p, bytes).at(&p)?)
    }

    /// Moves the staging folder into place (replacing an old one when allowed).
    pub fn commit(mut self) -> Result<PathBuf> {
        if self.dest.exists() {
            if !self.overwrite {
                return Err(SynthError::OutputExists(self.dest.clone()));
            }
            let old = self.tmp.with_file_name(format!(
                ".{}.old-{}",
                self.dest
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                std::process::id()
            ));
            std::fs::rename(&self.dest, &old).at(&self.dest)?;
            std::fs::rename(&self.tmp, &self.dest).at(&self.dest)?;
            std::fs::remove_dir_all(&old).at(&old)?;
        } else {
            std::fs::rename(&self.tmp, &self.dest).at(&self.dest)?;
        }
        self.committed = true;
        Ok(self.dest.clone())
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn c_exponent_format() {
        assert_eq!(format_c_exp(0.93817085, 7), "9.3817085e-001");
        assert_eq!(format_c_exp(-1.4903377, 7), "-1.4903377e+000");
        assert_eq!(format_c_exp(0.0, 7), "0.0000000e+000");
        assert_eq!(format_c_exp(-0.0, 7), "0.0000000e+000");
        assert_eq!(format_c_exp(1.0, 7), "1.0000000e+000");
        assert_eq!(format_c_exp(-3.0e-12, 7), "-3.0000000e-012");
        assert_eq!(format_c_exp(123456.0, 2), "1.23e+005");
    }

    #[test]
    fn pose_txt_line_layout() {
        let m = Matrix4::new(
            0.93817085,
            -0.26860735,
            0.21809216,
            -1.4903377,
            0.16796641,
            0.90461522,
            0.39159104,
            -0.49737796,
            -0.30248943,
            -0.33076438,
            0.89383817,
            -0.054694783,
            0.0,
            0.0,
            0.0,
            1.0,
        );
        let s = format_pose_txt(&m);
        let first = s.split("\r\n").next().unwrap();
        // Hand-copied from the first line of 7-Scenes stairs seq-01/frame-000000.pose.txt.
        assert_eq!(
            first,
            "  9.3817085e-001\t -2.6860735e-001\t  2.1809216e-001\t -1.4903377e+000\t"
        );
        assert!(s.ends_with(
            "  0.0000000e+000\t  0.0000000e+000\t  0.0000000e+000\t  1.0000000e+000\t\r\n"
        ));
        assert_eq!(s.matches("\r\n").count(), 4);
    }

    #[test]
    fn names_and_split_files() {
        assert_eq!(
            seven_scenes_names(3, 12),
            (
                "seq-03/frame-000012.color.png".into(),
                "seq-03/frame-000012.depth.png".into(),
                "seq-03/frame-000012.pose.txt".into()
            )
        );
        assert_eq!(cambridge_name(2, 0), "seq2/frame00001.png");
        assert_eq!(cambridge_nvm_name(2, 0), "seq2/frame00001.jpg");
        assert_eq!(
            format_split_file(&[1, 2, 4]),
            "sequence1\r\nsequence2\r\nsequence4\r\n"
        );
    }

    #[test]
    fn nvm_layout() {
        let pose = Pose::from_centre_qvec([1.0, 2.0, 3.0], [1.0, 0.0, 0.0, 0.0]).unwrap();
        let s = format_nvm(
            &[NvmCamera {
                name: "seq1/frame00001.jpg".into(),
                focal: 525.0,
                pose,
            }],
            &[NvmPoint {
                xyz: [0.5, -0.25, 2.0],
                rgb: [1, 2, 3],
                measurements: vec![NvmMeasurement {
                    camera: 0,
                    feature: 7,
                    x: -1.5,
                    y: 2.25,
                }],
            }],
        );
        assert_eq!(
            s,
            "NVM_V3\n\n1\nseq1/frame00001.jpg 525 1 0 0 0 1 2 3 0 0\n\n1\n0.5 -0.25 2 1 2 3 1 0 7 -1.5 2.25\n"
        );
    }

    #[test]
    fn staging_commit_and_drop() {
        let dir = tempfile::tempdir().unwrap();
        {
            let s = Staging::new(dir.path(), "scene", false).unwrap();
            s.write("a.txt", b"x").unwrap();
            // Dropped without commit: nothing left.
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let s = Staging::new(dir.path(), "scene", false).unwrap();
        s.write("a.txt", b"x").unwrap();
        let dest = s.commit().unwrap();
        assert_eq!(std::fs::read(dest.join("a.txt")).unwrap(), b"x");
        assert!(matches!(
            Staging::new(dir.path(), "scene", false),
            Err(SynthError::OutputExists(_))
        ));
        let s = Staging::new(dir.path(), "scene", true).unwrap();
        s.write("b.txt", b"y").unwrap();
        let dest = s.commit().unwrap();
        assert!(!dest.join("a.txt").exists() && dest.join("b.txt").exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn layout_serde_and_strum_names_agree() {
        for layout in [Layout::SevenScenes, Layout::Cambridge] {
            let json = serde_json::to_string(&layout).unwrap();
            assert_eq!(json, format!("\"{layout}\""));
            assert_eq!(layout.to_string().parse::<Layout>(), Ok(layout));
        }
        assert_eq!("7-scenes".parse::<Layout>(), Ok(Layout::SevenScenes));
        assert_eq!(
            "7Scenes".parse::<Layout>(),
            Err("unknown layout \"7Scenes\": expected 7scenes or cambridge".to_string())
        );
    }
}
