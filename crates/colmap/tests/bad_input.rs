//! Bad input: truncations at every byte, corrupted fields, broken cross references.
//! Each must give a located error, never a panic.

mod small;

use colmap::{ColmapError, Format, Location, Problem, Table};
use geometry::GeometryError;
use small::{files, model, parse_bin, parse_txt, text_files};

fn problem(e: &ColmapError) -> &Problem {
    e.problem().unwrap_or_else(|| panic!("no problem in {e}"))
}

fn path_of(e: &ColmapError) -> String {
    match e {
        ColmapError::Parse { path, .. } => path.display().to_string(),
        other => panic!("not a parse error: {other}"),
    }
}

fn byte_offset(e: &ColmapError) -> usize {
    match e.location() {
        Some(Location::Byte { offset, .. }) => *offset,
        other => panic!("no byte offset: {other:?} in {e}"),
    }
}

fn line_col(e: &ColmapError) -> (usize, usize) {
    match e.location() {
        Some(Location::Line { line, column, .. }) => (*line, *column),
        other => panic!("no line: {other:?} in {e}"),
    }
}

#[test]
fn small_model_parses_in_both_formats() {
    let rec = model();
    assert_eq!(parse_bin(&files(&rec, Format::Binary)).unwrap(), rec);
    assert_eq!(parse_txt(&text_files(&rec)).unwrap(), rec);
}

#[test]
fn binary_truncated_at_every_byte_is_an_error() {
    let rec = model();
    let full = files(&rec, Format::Binary);
    for (k, table) in small::TABLES.iter().enumerate() {
        for cut in 0..full[k].len() {
            let mut f = full.clone();
            f[k].truncate(cut);
            let e = parse_bin(&f).expect_err(&format!("{} cut at {cut} parsed", table.stem()));
            assert!(
                path_of(&e).ends_with(&format!("{}.bin", table.stem())),
                "cut {} at {cut}: {e}",
                table.stem()
            );
            assert!(
                matches!(
                    problem(&e),
                    Problem::Truncated { .. }
                        | Problem::CountTooLarge { .. }
                        | Problem::UnterminatedName
                ),
                "{e}"
            );
            assert!(byte_offset(&e) <= cut, "{e}");
        }
    }
}

#[test]
fn text_truncated_at_every_byte_never_panics() {
    // A shorter text file can still be a valid model (a number losing its last digits),
    // so only the absence of panics is required here; most cuts are errors.
    let full = text_files(&model());
    let mut errors = 0;
    let mut total = 0;
    for k in 0..5 {
        for cut in 0..full[k].len() {
            if !full[k].is_char_boundary(cut) {
                continue;
            }
            let mut f = full.clone();
            f[k].truncate(cut);
            total += 1;
            if let Err(e) = parse_txt(&f) {
                errors += 1;
                assert!(!e.to_string().is_empty());
            }
        }
    }
    assert!(errors * 2 > total, "{errors} errors in {total} cuts");
}

fn set(buf: &mut [u8], at: usize, bytes: &[u8]) {
    buf[at..at + bytes.len()].copy_from_slice(bytes);
}

#[test]
fn binary_corrupted_fields() {
    let full = files(&model(), Format::Binary);
    // cameras.bin: u64 count, then camera_id u32 at 8, model_id i32 at 12.
    let mut f = full.clone();
    set(&mut f[0], 12, &99i32.to_le_bytes());
    let e = parse_bin(&f).unwrap_err();
    assert!(matches!(
        problem(&e),
        Problem::Geometry {
            source: GeometryError::UnknownModelId(99),
            ..
        }
    ));
    assert_eq!(byte_offset(&e), 12);
    assert!(
        e.to_string()
            .contains("cameras.bin: byte 12 (camera #0 (id 1))"),
        "{e}"
    );

    // A model id of another parameter count desynchronises the rest: still an error.
    let mut f = full.clone();
    set(&mut f[0], 12, &6i32.to_le_bytes()); // FULL_OPENCV, 12 params
    assert!(parse_bin(&f).is_err());

    // NaN camera parameter (first param at 8 + 4 + 4 + 8 + 8 = 32).
    let mut f = full.clone();
    set(&mut f[0], 32, &f64::NAN.to_le_bytes());
    let e = parse_bin(&f).unwrap_err();
    assert!(
        matches!(
            problem(&e),
            Problem::Geometry {
                source: GeometryError::NonFiniteParam { .. },
                ..
            }
        ),
        "{e}"
    );

    // images.bin: count u64, image_id at 8, qw at 12.
    let mut f = full.clone();
    set(&mut f[1], 12, &f64::NAN.to_le_bytes());
    let e = parse_bin(&f).unwrap_err();
    assert!(
        matches!(
            problem(&e),
            Problem::Geometry {
                source: GeometryError::NonFinite { .. },
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("image #0 (id 1)"), "{e}");

    // A quaternion far from unit norm.
    let mut f = full.clone();
    set(&mut f[1], 12, &3.0f64.to_le_bytes());
    let e = parse_bin(&f).unwrap_err();
    assert!(
        matches!(
            problem(&e),
            Problem::Geometry {
                source: GeometryError::QuaternionNorm { .. },
                ..
            }
        ),
        "{e}"
    );

    // Absurd counts that would allocate terabytes.
    for (k, at, what) in [
        (0, 0, "cameras"),
        (1, 0, "images"),
        (2, 0, "points3D"),
        (3, 0, "rigs"),
        (4, 0, "frames"),
    ] {
        let mut f = full.clone();
        set(&mut f[k], at, &u64::MAX.to_le_bytes());
        let e = parse_bin(&f).unwrap_err();
        assert!(
            matches!(
                problem(&e),
                Problem::CountTooLarge {
                    count: u64::MAX,
                    ..
                }
            ),
            "{what}: {e}"
        );
    }
    // Number of points2D of the first image: after id, pose, camera id and name.
    let name_len = "rig/cam1/0001.png".len() + 1;
    let n_pts_at = 8 + 4 + 56 + 4 + name_len;
    let mut f = full.clone();
    assert_eq!(f[1][n_pts_at..n_pts_at + 8], 3u64.to_le_bytes());
    set(&mut f[1], n_pts_at, &(1u64 << 60).to_le_bytes());
    let e = parse_bin(&f).unwrap_err();
    assert!(
        matches!(
            problem(&e),
            Problem::CountTooLarge {
                what: "points2D",
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(byte_offset(&e), n_pts_at);
    // Track length of the first point: after id, xyz, rgb, error.
    let track_at = 8 + 8 + 24 + 3 + 8;
    let mut f = full.clone();
    set(&mut f[2], track_at, &(u64::MAX / 2).to_le_bytes());
    let e = parse_bin(&f).unwrap_err();
    assert!(
        matches!(
            problem(&e),
            Problem::CountTooLarge {
                what: "track elements",
                ..
            }
        ),
        "{e}"
    );
    // Frame data ids (u32) after id, rig id and pose.
    let mut f = full.clone();
    set(&mut f[4], 8 + 4 + 4 + 56, &u32::MAX.to_le_bytes());
    let e = parse_bin(&f).unwrap_err();
    assert!(
        matches!(
            problem(&e),
            Problem::CountTooLarge {
                what: "data ids",
                ..
            }
        ),
        "{e}"
    );
    // Rig sensors (u32) after the rig id.
    let mut f = full.clone();
    set(&mut f[3], 12, &u32::MAX.to_le_bytes());
    let e = parse_bin(&f).unwrap_err();
    assert!(
        matches!(
            problem(&e),
            Problem::CountTooLarge {
                what: "sensors",
                ..
            }
        ),
        "{e}"
    );

    // Unknown sensor type (reference sensor type at 16).
    let mut f = full.clone();
    set(&mut f[3], 16, &7i32.to_le_bytes());
    let e = parse_bin(&f).unwrap_err();
    assert_eq!(problem(&e), &Problem::UnknownSensorType("7".into()));

    // NaN in a point.
    let mut f = full.clone();
    set(&mut f[2], 16, &f64::INFINITY.to_le_bytes());
    let e = parse_bin(&f).unwrap_err();
    assert_eq!(problem(&e), &Problem::NonFinite { what: "xyz" });

    // Bytes after the last record.
    let mut f = full.clone();
    f[2].extend_from_slice(&[0, 1, 2]);
    let e = parse_bin(&f).unwrap_err();
    assert_eq!(problem(&e), &Problem::TrailingBytes { count: 3 });
    assert_eq!(byte_offset(&e), full[2].len());

    // Invalid UTF-8 in a name.
    let mut f = full.clone();
    f[1][8 + 4 + 56 + 4] = 0xFF;
    let e = parse_bin(&f).unwrap_err();
    assert_eq!(problem(&e), &Problem::NameNotUtf8);
}

/// Cross-record checks: each inconsistency is refused and located.
#[test]
fn inconsistent_models_are_refused() {
    let base = model();
    let check = |edit: &dyn Fn(&mut colmap::Reconstruction),
                 table: Table,
                 expect: &dyn Fn(&Problem) -> bool| {
        let mut rec = base.clone();
        edit(&mut rec);
        let e = rec.validate().unwrap_err();
        assert!(expect(problem(&e)), "{e}");
        // The same model, written and parsed back, names the file of the table.
        if let (Ok(bin), Ok(txt)) = (
            std::panic::catch_unwind(|| files(&rec, Format::Binary)),
            std::panic::catch_unwind(|| text_files(&rec)),
        ) {
            let e = parse_bin(&bin).unwrap_err();
            assert!(
                path_of(&e).ends_with(&format!("{}.bin", table.stem())),
                "{e}"
            );
            let e = parse_txt(&txt).unwrap_err();
            assert!(
                path_of(&e).ends_with(&format!("{}.txt", table.stem())),
                "{e}"
            );
        }
    };
    check(&|r| r.images[0].camera_id = 9, Table::Images, &|p| {
        *p == Problem::UnknownCamera(9)
    });
    check(
        &|r| r.points3d[0].track[0].image_id = 42,
        Table::Points3D,
        &|p| *p == Problem::UnknownImage(42),
    );
    check(
        &|r| r.points3d[0].track[0].point2d_idx = 3,
        Table::Points3D,
        &|p| matches!(p, Problem::Point2DOutOfRange { idx: 3, .. }),
    );
    check(
        &|r| r.points3d[0].track[0].point2d_idx = 1,
        Table::Points3D,
        &|p| matches!(p, Problem::TrackMismatch { .. }),
    );
    check(
        &|r| {
            let el = r.points3d[0].track[0];
            r.points3d[0].track.push(el);
        },
        Table::Points3D,
        &|p| matches!(p, Problem::DuplicateObservation { .. }),
    );
    check(
        &|r| {
            r.points3d[0].track.pop();
        },
        Table::Images,
        &|p| matches!(p, Problem::DanglingObservation { point3d_id: 1, .. }),
    );
    check(&|r| r.points3d[2].id = 2, Table::Points3D, &|p| {
        matches!(p, Problem::DuplicateId { id: 2, .. })
    });
    check(&|r| r.cameras[1].camera_id = 1, Table::Cameras, &|p| {
        matches!(p, Problem::DuplicateId { id: 1, .. })
    });
    check(
        &|r| r.images[2].name = r.images[0].name.clone(),
        Table::Images,
        &|p| matches!(p, Problem::DuplicateName { .. }),
    );
    check(&|r| r.frames[1].data_ids[0].id = 9, Table::Images, &|p| {
        *p == Problem::ImageWithoutFrame
    });
    check(&|r| r.frames[1].data_ids[0].id = 1, Table::Frames, &|p| {
        matches!(p, Problem::ImageInTwoFrames { .. })
    });
    check(&|r| r.frames[0].rig_id = 5, Table::Frames, &|p| {
        *p == Problem::UnknownRig(5)
    });
    check(
        &|r| r.rigs[0].sensors[0].sensor_from_rig = None,
        Table::Images,
        &|p| matches!(p, Problem::SensorPoseMissing { camera_id: 2, .. }),
    );
    check(
        &|r| {
            r.rigs[0].sensors.remove(0);
        },
        Table::Images,
        &|p| matches!(p, Problem::SensorNotInRig { camera_id: 2, .. }),
    );
    check(&|r| r.images[1].tvec[0] += 1e-6, Table::Images, &|p| {
        matches!(p, Problem::PoseMismatch { .. })
    });
    check(
        &|r| r.images[0].points2d[1].xy[1] = f64::NAN,
        Table::Images,
        &|p| matches!(p, Problem::NonFinite { .. }),
    );
}

#[test]
fn text_errors_name_line_and_column() {
    let full = text_files(&model());
    let with = |k: usize, edit: &dyn Fn(&str) -> String| {
        let mut f = full.clone();
        f[k] = edit(&f[k]);
        parse_txt(&f).unwrap_err()
    };
    // cameras.txt: line 4 is camera 1 (after 3 header lines).
    let e = with(0, &|s| {
        s.replace(
            "1 PINHOLE 640 480 500 510 320 240",
            "1 PINHOLE 640 480 500 510 320",
        )
    });
    assert!(
        matches!(
            problem(&e),
            Problem::Geometry {
                source: GeometryError::ParamCount {
                    expected: 4,
                    got: 3,
                    ..
                },
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(line_col(&e), (4, 19));
    assert!(
        e.to_string()
            .starts_with("model/cameras.txt: line 4, column 19 (camera #0 (id 1))"),
        "{e}"
    );
    let e = with(0, &|s| s.replace("PINHOLE", "PINHOLY"));
    assert!(
        matches!(
            problem(&e),
            Problem::Geometry {
                source: GeometryError::UnknownModelName(_),
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(line_col(&e), (4, 3));
    let e = with(0, &|s| s.replace("640", "-640"));
    assert!(matches!(problem(&e), Problem::BadToken { .. }), "{e}");
    let e = with(0, &|s| s.replace("510", "nan"));
    assert_eq!(
        problem(&e),
        &Problem::NonFinite {
            what: "camera parameter"
        }
    );

    // images.txt: malformed number, missing fields, NaN pose, bad point3D id.
    let img = &full[1];
    let first_data_line = img.lines().position(|l| !l.starts_with('#')).unwrap() + 1;
    let e = with(1, &|s| s.replacen("rig/cam1/0001.png", "", 1));
    assert_eq!(problem(&e), &Problem::MissingToken { expected: "NAME" });
    assert_eq!(line_col(&e).0, first_data_line);
    let e = with(1, &|s| s.replacen("10.5 20.25 1", "10.5 20.2.5 1", 1));
    assert!(
        matches!(
            problem(&e),
            Problem::BadToken {
                expected: "Y of a point2D",
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(line_col(&e), (first_data_line + 1, 6));
    let e = with(1, &|s| s.replacen("10.5 20.25 1", "10.5 20.25 -2", 1));
    assert!(matches!(problem(&e), Problem::BadToken { .. }), "{e}");
    let e = with(1, &|s| s.replacen("10.5 20.25 1", "10.5 20.25", 1));
    assert!(
        matches!(
            problem(&e),
            Problem::BadToken { .. } | Problem::MissingToken { .. }
        ),
        "{e}"
    );
    let e = with(1, &|s| {
        let mut lines: Vec<String> = s.lines().map(str::to_string).collect();
        let fields: Vec<&str> = lines[first_data_line - 1].split(' ').collect();
        let mut f: Vec<String> = fields.iter().map(|x| x.to_string()).collect();
        f[1] = "NaN".into();
        lines[first_data_line - 1] = f.join(" ");
        lines.join("\n") + "\n"
    });
    assert!(matches!(problem(&e), Problem::NonFinite { .. }), "{e}");
    assert_eq!(line_col(&e), (first_data_line, 3));
    // An image line at the end of the file without its POINTS2D line.
    let e = with(1, &|s| {
        let mut lines: Vec<&str> = s.lines().collect();
        lines.pop();
        lines.join("\n") + "\n"
    });
    assert_eq!(problem(&e), &Problem::MissingPointsLine);
    // Extra tokens after the name (a name with a space).
    let e = with(1, &|s| {
        s.replacen("rig/cam1/0001.png", "rig/cam1/0001 .png", 1)
    });
    assert!(
        matches!(problem(&e), Problem::ExtraTokens { count: 1, .. }),
        "{e}"
    );

    // points3D.txt: color out of range, odd track.
    let e = with(2, &|s| s.replacen(" 255 0 7 ", " 256 0 7 ", 1));
    assert!(
        matches!(
            problem(&e),
            Problem::BadToken {
                expected: "R (0-255)",
                ..
            }
        ),
        "{e}"
    );
    let e = with(2, &|s| s.replacen("0.5 1 0 2 1", "0.5 1 0 2", 1));
    assert!(matches!(problem(&e), Problem::MissingToken { .. }), "{e}");

    // rigs.txt / frames.txt: negative and absurd counts, unknown sensor types.
    let e = with(3, &|s| s.replacen("1 3 CAMERA 1", "1 -3 CAMERA 1", 1));
    assert!(
        matches!(
            problem(&e),
            Problem::BadToken {
                expected: "NUM_SENSORS (unsigned 32-bit integer)",
                ..
            }
        ),
        "{e}"
    );
    let e = with(3, &|s| {
        s.replacen("1 3 CAMERA 1", "1 4000000000 CAMERA 1", 1)
    });
    assert!(matches!(problem(&e), Problem::MissingToken { .. }), "{e}");
    let e = with(3, &|s| s.replacen("IMU", "LIDAR", 1));
    assert_eq!(problem(&e), &Problem::UnknownSensorType("LIDAR".into()));
    let e = with(4, &|s| {
        s.lines()
            .map(|l| {
                if l.starts_with("2 1 ") {
                    l.replace(" 1 CAMERA 1 3", " -1 CAMERA 1 3")
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    });
    assert!(
        matches!(
            problem(&e),
            Problem::BadToken {
                expected: "NUM_DATA_IDS (unsigned 32-bit integer)",
                ..
            }
        ),
        "{e}"
    );
    let e = with(4, &|s| {
        s.lines()
            .map(|l| {
                if l.starts_with("2 1 ") {
                    l.replace(" 1 CAMERA 1 3", " 4294967295 CAMERA 1 3")
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    });
    assert!(matches!(problem(&e), Problem::MissingToken { .. }), "{e}");
}

#[test]
fn empty_second_line_and_invalid_ids_in_text() {
    let rec = model();
    let txt = text_files(&rec);
    // Image 3 has no 2D points: its POINTS2D line is empty and must not be skipped.
    let img = &txt[1];
    assert!(img.contains("rig/cam1/0002.png\n\n"), "{img}");
    assert!(img.contains(" -1 "));
    let parsed = parse_txt(&txt).unwrap();
    assert_eq!(parsed.image(3).unwrap().points2d.len(), 0);
    assert_eq!(
        parsed.image(1).unwrap().points2d[1].point3d_id,
        colmap::INVALID_POINT3D_ID
    );
    // An image without points followed by another image: the empty line belongs to the
    // first image (a reader that skipped it would take the next image line as points).
    let mut f = txt.clone();
    let header_end = f[1].find("\n1 ").unwrap() + 1;
    let (head, body) = f[1].split_at(header_end);
    let mut blocks: Vec<&str> = body.split_inclusive('\n').collect();
    // Move image 3 (2 lines, the last two) to the front.
    let last_two: Vec<&str> = blocks.split_off(blocks.len() - 2);
    f[1] = format!("{head}{}{}", last_two.concat(), blocks.concat());
    let reordered = parse_txt(&f).unwrap();
    assert_eq!(reordered.images[0].image_id, 3);
    assert_eq!(reordered.images[0].points2d.len(), 0);
    assert_eq!(reordered.images[1].points2d.len(), 3);
}

#[test]
fn writers_refuse_unrepresentable_models() {
    let mut rec = model();
    rec.images[0].name = "has space.png".into();
    let e = colmap::io::encode(&rec, Table::Images, Format::Text).unwrap_err();
    assert!(matches!(problem(&e), Problem::BadName(_)), "{e}");
    rec.images[0].name = "nul\0.png".into();
    let e = colmap::io::encode(&rec, Table::Images, Format::Binary).unwrap_err();
    assert!(matches!(problem(&e), Problem::BadName(_)), "{e}");
}

#[test]
fn missing_model_directory() {
    let tmp = tempfile::tempdir().unwrap();
    let e = colmap::read(tmp.path()).unwrap_err();
    assert!(matches!(e, ColmapError::MissingModel { .. }), "{e}");
    // Only two of the three binary files: falls back to text, which is absent too.
    std::fs::write(tmp.path().join("cameras.bin"), 0u64.to_le_bytes()).unwrap();
    std::fs::write(tmp.path().join("images.bin"), 0u64.to_le_bytes()).unwrap();
    assert!(matches!(
        colmap::read(tmp.path()).unwrap_err(),
        ColmapError::MissingModel { .. }
    ));
    std::fs::write(tmp.path().join("points3D.bin"), 0u64.to_le_bytes()).unwrap();
    let empty = colmap::read(tmp.path()).unwrap();
    assert_eq!(empty, colmap::Reconstruction::default());
}

/// A legacy model (no rigs/frames files) gets its frames from the images, so its errors
/// still name the images file.
#[test]
fn legacy_model_errors_name_the_images_file() {
    let mut f = text_files(&model());
    f[1] = f[1].replacen(" 1 rig/cam1/0001.png", " 9 rig/cam1/0001.png", 1);
    let e = colmap::text::parse_model(
        std::path::Path::new("model"),
        &colmap::text::TextFiles {
            cameras: &f[0],
            images: &f[1],
            points3d: &f[2],
            rigs: None,
            frames: None,
        },
    )
    .unwrap_err();
    assert!(path_of(&e).ends_with("images.txt"), "{e}");
    assert_eq!(problem(&e), &Problem::UnknownCamera(9));
    // Empty rigs and frames files count as absent (COLMAP's rule: no rig and no frame).
    let bin = files(&model(), Format::Binary);
    let legacy = colmap::binary::parse_model(
        std::path::Path::new("model"),
        &colmap::binary::BinaryFiles {
            cameras: &bin[0],
            images: &bin[1],
            points3d: &bin[2],
            rigs: Some(&0u64.to_le_bytes()),
            frames: Some(&0u64.to_le_bytes()),
        },
    );
    // The images of the small model are posed through a rig with a second camera, so
    // the trivial frames (rig = camera) still agree: each image keeps its stored pose.
    let legacy = legacy.unwrap();
    assert_eq!(legacy.rigs.len(), 2);
    assert_eq!(legacy.frames.len(), 3);
    assert_eq!(legacy.images, model().images);
}

/// A camera that cannot exist (focal length <= 0, size 0, principal point far outside)
/// is refused by both readers and by `validate`, naming the file and the camera id
/// (docs/errors.md): it never reaches the import or refine.
#[test]
fn impossible_cameras_are_refused_naming_the_file_and_camera_id() {
    let base = model();
    for (edit, expect) in [
        (
            (&|c: &mut geometry::Camera| c.params[0] = -500.0) as &dyn Fn(&mut geometry::Camera),
            "focal length fx = -500 must be positive and finite",
        ),
        (
            &|c| c.params[1] = 0.0,
            "focal length fy = 0 must be positive",
        ),
        (&|c| c.width = 0, "camera size 0x480 is invalid"),
        (
            &|c| c.params[2] = 1e12,
            "principal point cx = 1000000000000",
        ),
    ] {
        let mut rec = base.clone();
        edit(&mut rec.cameras[0].camera);
        let e = rec.validate().unwrap_err();
        assert!(e.to_string().contains(expect), "{e}");
        assert!(e.to_string().contains("camera #0 (id 1)"), "{e}");
        let e = parse_bin(&files(&rec, Format::Binary)).unwrap_err();
        assert!(path_of(&e).ends_with("cameras.bin"), "{e}");
        assert!(
            e.to_string().contains("camera #0 (id 1)") && e.to_string().contains(expect),
            "{e}"
        );
        let e = parse_txt(&text_files(&rec)).unwrap_err();
        assert!(path_of(&e).ends_with("cameras.txt"), "{e}");
        assert_eq!(line_col(&e).0, 4, "{e}");
        assert!(
            e.to_string().contains("camera #0 (id 1)") && e.to_string().contains(expect),
            "{e}"
        );
    }
}

/// The last line of points3D.txt, `ID X Y Z R G B ERROR IMAGE_ID POINT2D_IDX ...`.
fn cut_last_track_element(text: &str) -> String {
    let body = text.strip_suffix('\n').unwrap();
    let mut tokens: Vec<&str> = body.rsplitn(3, ' ').collect();
    // [POINT2D_IDX, IMAGE_ID, rest]: keep the rest, which ends at a token boundary.
    let rest = tokens.pop().unwrap();
    assert_eq!(tokens.len(), 2, "{body:?}");
    rest.to_string()
}

/// A points3D.txt cut at a token boundary (between two track elements) still parses:
/// the cut names points3D.txt and its last line, not the images.txt observation the
/// lost element leaves dangling (docs/errors.md). The small model and, with the sample
/// data, a real model written by pycolmap.
#[test]
fn points3d_txt_cut_at_a_token_boundary_names_points3d_txt() {
    // The small model's last point (id 7) has no track: cut the file inside the line
    // of point 2, before it.
    let full = text_files(&model());
    let lines: Vec<&str> = full[2].lines().collect();
    let point2_line = lines.len() - 1;
    assert!(lines[point2_line - 1].starts_with("2 "), "{lines:?}");
    let up_to_point2: String = lines[..point2_line]
        .iter()
        .map(|l| format!("{l}\n"))
        .collect();
    let mut f = full.clone();
    f[2] = cut_last_track_element(&up_to_point2);
    let e = parse_txt(&f).unwrap_err();
    assert!(path_of(&e).ends_with("points3D.txt"), "{e}");
    assert_eq!(line_col(&e).0, point2_line, "{e}");
    assert!(
        matches!(problem(&e), Problem::CutShort { evidence, then }
            if evidence.contains("without the line end") && then.contains("images.txt")),
        "{e}"
    );
    // The same cut with the line end put back (a cut at the end of a line): the
    // header's count of points shows it.
    f[2].push('\n');
    let e = parse_txt(&f).unwrap_err();
    assert!(path_of(&e).ends_with("points3D.txt"), "{e}");
    assert_eq!(line_col(&e).0, point2_line, "{e}");
    assert!(
        e.to_string()
            .contains("its header (line 3) says 3 points, but it holds 2 (this line is the last)"),
        "{e}"
    );
    // A consistent model without the last line end reads as it is.
    let mut f = full.clone();
    f[2].pop();
    assert_eq!(parse_txt(&f).unwrap(), model());

    let Some(scene) = testkit::sample::sample_data("colmap-maupertuis") else {
        return;
    };
    for sub in ["model-txt", "model-original-txt"] {
        let tmp = tempfile::tempdir().unwrap();
        let src = scene.join(sub);
        for entry in std::fs::read_dir(&src).unwrap() {
            let entry = entry.unwrap();
            std::fs::copy(entry.path(), tmp.path().join(entry.file_name())).unwrap();
        }
        let points = tmp.path().join("points3D.txt");
        let text = std::fs::read_to_string(&points).unwrap();
        let lines = text.lines().count();
        std::fs::write(&points, cut_last_track_element(&text)).unwrap();
        let e = colmap::read_text(tmp.path()).unwrap_err();
        assert_eq!(path_of(&e), points.display().to_string(), "{sub}: {e}");
        assert_eq!(line_col(&e).0, lines, "{sub}: {e}");
        assert!(
            e.to_string().contains("cut short") && e.to_string().contains("images.txt"),
            "{sub}: {e}"
        );
        // Cut at the end of a line: the header's count of points tells.
        let keep = text.lines().count() - 2;
        let cut: String = text.lines().take(keep).map(|l| format!("{l}\n")).collect();
        std::fs::write(&points, cut).unwrap();
        let e = colmap::read_text(tmp.path()).unwrap_err();
        assert_eq!(path_of(&e), points.display().to_string(), "{sub}: {e}");
        assert_eq!(line_col(&e).0, keep, "{sub}: {e}");
        assert!(
            e.to_string()
                .contains("header (line 3) says 1039 points, but it holds 1037"),
            "{sub}: {e}"
        );
    }
}
