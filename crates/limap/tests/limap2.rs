//! LIMAP 2.0 folders (docs/formats.md section 2, "LIMAP 2.0"): detection beside the 1.x
//! layout, the content they give, and one test per refusal (docs/errors.md).

use std::path::Path;

use colmap::synthetic::{SyntheticSpec, large_model};
use limap::structures::{
    GROUPS3D_FILE, Group2dRecord, INVALID_LINE3D_ID, LINES3D_FILE, Line2dRecord, Line3dRecord,
    STRUCTURES2D_FILE, Structure2dRecord, WIREFRAME3D_FILE, format_groups3d, format_lines3d,
    format_structures2d, format_wireframe3d,
};
use limap::{Layout, LimapDir, LimapDirOptions, LimapError, SegmentsOrigin, write_segments};

/// Image ids of the fixture's model.
fn image_ids(root: &Path) -> Vec<u32> {
    let model = colmap::read(&root.join("final_model")).unwrap();
    let mut ids: Vec<u32> = model.images.iter().map(|i| i.image_id).collect();
    ids.sort();
    ids
}

fn structures(ids: &[u32]) -> Vec<Structure2dRecord> {
    ids.iter()
        .enumerate()
        .map(|(k, &image_id)| Structure2dRecord {
            image_id,
            num_points: 0,
            lines: (0..3)
                .map(|r| Line2dRecord {
                    segment: [k as f64, r as f64, k as f64 + 10.0, r as f64 + 20.5],
                    score: 1.0,
                    line3d_id: if r == 0 { 7 } else { INVALID_LINE3D_ID },
                })
                .collect(),
            groups: vec![],
            wireframe: vec![],
        })
        .collect()
}

fn lines(ids: &[u32]) -> Vec<Line3dRecord> {
    vec![
        Line3dRecord {
            id: 7,
            line: [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]],
            track: ids.iter().map(|&i| (i, 0)).collect(),
            uncertainty: 0.01,
        },
        Line3dRecord {
            id: 9,
            line: [[0.0, 1.0, 1.0], [1.0, 1.0, 1.0]],
            track: vec![(ids[0], 2), (ids[1], 1)],
            uncertainty: 0.02,
        },
    ]
}

/// A LIMAP 2.0 output folder after LIMAP's clean-up (no frontend/): a 4-image model and
/// two 3D lines, one seen in all 4 images, one in 2.
fn fixture() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("final_model");
    std::fs::create_dir_all(model.join("structures")).unwrap();
    let rec = large_model(&SyntheticSpec {
        num_points3d: 4,
        num_images: 4,
        num_observations: 8,
        unmatched_per_image: 1,
        images_per_camera: 4,
        seed: 1,
    });
    colmap::write_binary(&rec, &model).unwrap();
    let ids = image_ids(dir.path());
    write_structures(dir.path(), &structures(&ids), &lines(&ids));
    std::fs::write(
        model.join("structures").join(GROUPS3D_FILE),
        format_groups3d(&[]),
    )
    .unwrap();
    std::fs::write(
        model.join("structures").join(WIREFRAME3D_FILE),
        format_wireframe3d(&[]),
    )
    .unwrap();
    std::fs::write(dir.path().join("metainfos.txt"), "").unwrap();
    dir
}

fn write_structures(root: &Path, s: &[Structure2dRecord], l: &[Line3dRecord]) {
    let dir = root.join("final_model/structures");
    std::fs::write(dir.join(STRUCTURES2D_FILE), format_structures2d(s)).unwrap();
    std::fs::write(dir.join(LINES3D_FILE), format_lines3d(l)).unwrap();
}

fn load(root: &Path) -> Result<LimapDir, LimapError> {
    LimapDir::load(root, &LimapDirOptions::default())
}

#[test]
fn reads_the_model_structures_and_tracks() {
    let d = fixture();
    let dir = load(d.path()).unwrap();
    let ids = image_ids(d.path());
    assert_eq!(dir.layout, Layout::Limap2);
    assert_eq!(dir.root, d.path());
    assert_eq!(dir.segments_origin, SegmentsOrigin::Structures);
    assert_eq!(dir.image_list.ids().collect::<Vec<_>>(), ids);
    assert_eq!(dir.segments.len(), 4);
    assert!(dir.segments.values().all(|s| s.len() == 3));
    assert_eq!(dir.tracks.len(), 2);
    assert_eq!(dir.line3d_ids, Some(vec![7, 9]));
    let t = &dir.tracks[1];
    assert_eq!(t.image_ids, vec![ids[0], ids[1]]);
    assert_eq!(t.line_ids, vec![2, 1]);
    assert_eq!(
        t.lines2d.as_ref().unwrap()[0],
        dir.segments[&ids[0]].lines[2]
    );
    // The alltracks label set: the track seen in >= 4 images, without 2D segments as
    // LIMAP 1.x's alltracks.txt holds it.
    let all = dir.alltracks.as_ref().unwrap();
    assert_eq!(all.len(), 1);
    assert_eq!(all[0].image_ids, dir.tracks[0].image_ids);
    assert!(all[0].lines2d.is_none());
    assert!(dir.check().is_ok());
    let groups: Vec<_> = dir
        .input_files()
        .unwrap()
        .into_iter()
        .map(|g| (g.name, g.files))
        .collect();
    assert_eq!(groups[0].0, "limap");
    assert!(groups[0].1.contains(&"images.bin".to_string()));
    assert_eq!(groups[1].1, vec![STRUCTURES2D_FILE.to_string()]);
    assert_eq!(
        groups[2].1,
        vec![LINES3D_FILE.to_string(), STRUCTURES2D_FILE.to_string()]
    );
}

#[test]
fn final_model_itself_reads_the_same() {
    let d = fixture();
    let outer = load(d.path()).unwrap();
    let inner = load(&d.path().join("final_model")).unwrap();
    assert_eq!(inner.root, outer.root);
    assert_eq!(inner.tracks, outer.tracks);
    assert_eq!(inner.segments, outer.segments);
}

#[test]
fn frontend_segments_are_used_and_checked_against_the_structures() {
    let d = fixture();
    let ids = image_ids(d.path());
    let from_structures = load(d.path()).unwrap();
    let seg_dir = d.path().join("frontend/line_detections/lsd/segments");
    std::fs::create_dir_all(&seg_dir).unwrap();
    for (id, s) in &from_structures.segments {
        write_segments(seg_dir.join(format!("segments_{id}.txt")), s).unwrap();
    }
    let dir = load(d.path()).unwrap();
    assert_eq!(dir.segments_origin, SegmentsOrigin::Detected);
    assert_eq!(dir.segments_dir, seg_dir);
    assert_eq!(dir.segments, from_structures.segments);
    // Segments that disagree with the rows the tracks point to are refused.
    let mut s = from_structures.segments[&ids[0]].clone();
    s.lines[2][0] += 5.0;
    write_segments(seg_dir.join(format!("segments_{}.txt", ids[0])), &s).unwrap();
    let e = load(d.path()).unwrap_err();
    assert!(matches!(e, LimapError::Inconsistent { .. }), "{e}");
}

#[test]
fn refuses_a_truncated_file_naming_file_and_record() {
    let d = fixture();
    let path = d.path().join("final_model/structures").join(LINES3D_FILE);
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() - 4]).unwrap();
    let e = load(d.path()).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, LimapError::Binary { .. }), "{msg}");
    assert!(
        msg.contains("lines3D.bin")
            && msg.contains("record 1 (3D line 9)")
            && msg.contains("truncated"),
        "{msg}"
    );
}

#[test]
fn refuses_an_unknown_version_as_bytes_after_the_last_record() {
    // The files carry no version number: bytes of another layout show as a record that
    // does not end where the file ends.
    let d = fixture();
    let path = d
        .path()
        .join("final_model/structures")
        .join(STRUCTURES2D_FILE);
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.extend_from_slice(&2u32.to_le_bytes());
    std::fs::write(&path, bytes).unwrap();
    let msg = load(d.path()).unwrap_err().to_string();
    assert!(
        msg.contains("structures2d.bin")
            && msg.contains("4 byte(s) after the last image record")
            && msg.contains("different version"),
        "{msg}"
    );
}

#[test]
fn refuses_an_unknown_record_type() {
    let d = fixture();
    let ids = image_ids(d.path());
    let mut s = structures(&ids);
    s[2].groups.push(Group2dRecord {
        group_type: 42,
        points: vec![],
        lines: vec![(0, 1.0)],
        group3d_id: 0,
    });
    write_structures(d.path(), &s, &lines(&ids));
    let msg = load(d.path()).unwrap_err().to_string();
    assert!(
        msg.contains("structures2d.bin")
            && msg.contains(&format!("record 2 (image {})", ids[2]))
            && msg.contains("unknown group type 42"),
        "{msg}"
    );
}

#[test]
fn refuses_an_image_the_model_lacks() {
    let d = fixture();
    let ids = image_ids(d.path());
    let mut s = structures(&ids);
    s[3].image_id = 999;
    write_structures(d.path(), &s, &lines(&ids));
    let e = load(d.path()).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, LimapError::Record { .. }), "{msg}");
    assert!(
        msg.contains("structures2d.bin")
            && msg.contains("record 3 (image 999)")
            && msg.contains("image 999 is not in the model"),
        "{msg}"
    );
}

#[test]
fn refuses_a_support_outside_the_structures() {
    let d = fixture();
    let ids = image_ids(d.path());
    let mut l = lines(&ids);
    l[1].track[1].1 = 3;
    write_structures(d.path(), &structures(&ids), &l);
    let msg = load(d.path()).unwrap_err().to_string();
    assert!(
        msg.contains("lines3D.bin")
            && msg.contains("record 1 (3D line 9), track element 1")
            && msg.contains("holds 3 line(s)"),
        "{msg}"
    );
    let mut l = lines(&ids);
    l[0].track[0].0 = 555;
    write_structures(d.path(), &structures(&ids), &l);
    let msg = load(d.path()).unwrap_err().to_string();
    assert!(
        msg.contains("image 555 has no record in structures2d.bin"),
        "{msg}"
    );
}

#[test]
fn refuses_a_missing_structure_file_naming_it() {
    let d = fixture();
    std::fs::remove_file(d.path().join("final_model/structures").join(LINES3D_FILE)).unwrap();
    let e = load(d.path()).unwrap_err();
    assert!(
        matches!(e, LimapError::Io(ref io) if io.path.ends_with(LINES3D_FILE)),
        "{e}"
    );
}

#[test]
fn refuses_a_1x_tracks_folder_and_an_unknown_layout() {
    let d = fixture();
    let options = LimapDirOptions {
        tracks_folder: Some("mytracks".into()),
        ..LimapDirOptions::default()
    };
    let msg = LimapDir::load(d.path(), &options).unwrap_err().to_string();
    assert!(msg.contains("LIMAP 1.x folders only"), "{msg}");
    // The default folder name (what `pl2map limap info` passes) is accepted.
    let options = LimapDirOptions {
        tracks_folder: Some("finaltracks".into()),
        ..LimapDirOptions::default()
    };
    LimapDir::load(d.path(), &options).unwrap();

    let empty = tempfile::tempdir().unwrap();
    let e = load(empty.path()).unwrap_err();
    assert!(matches!(e, LimapError::UnknownLayout { .. }), "{e}");
    assert!(e.to_string().contains("image_list.txt"), "{e}");
}
