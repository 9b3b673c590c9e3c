//! A LIMAP 1.x folder whose `image_list.txt` has LIMAP's list form
//! (`save_txt_imname_list`: the count, then one absolute image path per line; ids are the
//! positions from 0), as LIMAP 1.x's runners wrote it: the `limap-mini` fixture with its
//! ids renumbered from 0 and its list rewritten in that form reads as the same folder.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use limap::{LimapDir, LimapDirOptions, write_limap_dir};

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/limap-mini")
}

#[test]
fn a_list_form_image_list_with_absolute_paths_reads_with_ids_by_position() {
    let mini = LimapDir::load(fixture(), &LimapDirOptions::default()).unwrap();
    // The fixture's ids are 1..=6 in list order: in the list form they are 0..=5.
    let ids: Vec<u32> = mini.image_list.ids().collect();
    assert_eq!(ids, (1..=6).collect::<Vec<u32>>());
    let mut list = mini.image_list.clone();
    for (id, _) in &mut list.images {
        *id -= 1;
    }
    let segments: BTreeMap<u32, limap::Segments> = mini
        .segments
        .iter()
        .map(|(id, s)| (id - 1, s.clone()))
        .collect();
    let mut tracks = mini.tracks.clone();
    for t in &mut tracks {
        for id in &mut t.image_ids {
            *id -= 1;
        }
    }
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("limap");
    write_limap_dir(&root, "lsd", &list, &segments, &tracks).unwrap();
    let prefix = "/data/7scenes/";
    let mut text = format!("number of images, {}\n", list.len());
    for (_, name) in &list.images {
        text.push_str(&format!("{prefix}{name}\n"));
    }
    std::fs::write(root.join("image_list.txt"), &text).unwrap();
    // The file is what LIMAP itself writes: its own writer, run on the same names, gives
    // the same bytes (skipped with the reason when LIMAP is not installed).
    if let Some(python) = testkit::python::limap_python(&["limap"]) {
        let by_limap = tmp.path().join("image_list_by_limap.txt");
        let names: Vec<String> = list
            .images
            .iter()
            .map(|(_, n)| format!("{prefix}{n}"))
            .collect();
        testkit::python::run(
            std::process::Command::new(python)
                .arg("-c")
                .arg(
                    "import sys, limap.util.io as io; \
                     io.save_txt_imname_list(sys.argv[1], sys.argv[2:])",
                )
                .arg(&by_limap)
                .args(&names),
        );
        assert_eq!(std::fs::read_to_string(&by_limap).unwrap(), text);
    }

    let dir = LimapDir::load(&root, &LimapDirOptions::default()).unwrap();
    let expected: Vec<(u32, String)> = mini
        .image_list
        .images
        .iter()
        .map(|(id, n)| (id - 1, format!("{prefix}{n}")))
        .collect();
    assert_eq!(dir.image_list.images, expected);
    assert_eq!(dir.tracks, tracks);
    assert_eq!(dir.segments, segments);
    // Every cross-file check passes: the tracks' ids are the list's positions.
    let report = dir.check();
    assert!(report.is_ok(), "{report:?}");
}
