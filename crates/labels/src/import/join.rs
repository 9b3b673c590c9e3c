//! The join of the model's and LIMAP's images to the frames table, by name through
//! explicit [`NameMapping`]s (never a guess): frame id -> source image id, and every
//! name that does not join as a problem.

use super::problems::ImportProblem;
use crate::names::NameMapping;
use std::collections::HashMap;
use tables::frames::{Frame, Split};

/// What went wrong with one source (model or LIMAP) image name.
pub(super) enum NameProblem {
    Unmappable(String),
    NotInDataset(String),
    TestFrame(u32),
    /// (mapped name, id of the first source image with that name)
    Duplicate(String, u32),
}

/// Maps `(source id, source name)` to frames: frame id -> source id. Problems go
/// through `on`, which names them for its source.
pub(super) fn join_names(
    entries: impl Iterator<Item = (u32, String)>,
    mapping: &NameMapping,
    by_name: &HashMap<&str, &Frame>,
    allow_test: bool,
    problems: &mut Vec<ImportProblem>,
    test_skipped: &mut usize,
    on: impl Fn(u32, &str, NameProblem) -> ImportProblem,
) -> HashMap<u32, u32> {
    let mut out = HashMap::new();
    let mut seen: HashMap<String, u32> = HashMap::new();
    for (id, name) in entries {
        let mapped = match mapping.apply(&name) {
            Ok(m) => m,
            Err(reason) => {
                problems.push(on(id, &name, NameProblem::Unmappable(reason)));
                continue;
            }
        };
        if let Some(&first) = seen.get(&mapped) {
            problems.push(on(id, &name, NameProblem::Duplicate(mapped, first)));
            continue;
        }
        seen.insert(mapped.clone(), id);
        match by_name.get(mapped.as_str()) {
            None => problems.push(on(id, &name, NameProblem::NotInDataset(mapped))),
            Some(f) if f.split == Split::Test => {
                if allow_test {
                    *test_skipped += 1;
                } else {
                    problems.push(on(id, &name, NameProblem::TestFrame(f.id)));
                }
            }
            Some(f) => {
                out.insert(f.id, id);
            }
        }
    }
    out
}

/// The dataset root LIMAP 1.x put before every image name: LIMAP's runners write
/// absolute paths (`/data/7scenes/stairs/seq-01/frame-000000.color.png`) where the frames
/// table has dataset-relative names (`seq-01/frame-000000.color.png`). Some(prefix) when
/// every name is one prefix ending in `/` followed by a frames table name, that prefix
/// being the same for all and the only one that works; None when the names join as
/// they are, or when no single prefix explains every name (they are then reported as
/// they are, never guessed at one by one).
pub(super) fn limap_root_prefix(names: &[&str], by_name: &HashMap<&str, &Frame>) -> Option<String> {
    if names.iter().all(|n| by_name.contains_key(n)) {
        return None;
    }
    let first = names.first()?;
    let mut found: Option<&str> = None;
    for (i, _) in first.match_indices('/') {
        let prefix = &first[..=i];
        let fits = |n: &&str| {
            n.strip_prefix(prefix)
                .is_some_and(|rest| by_name.contains_key(rest))
        };
        if names.iter().all(fits) {
            if found.is_some() {
                return None;
            }
            found = Some(prefix);
        }
    }
    found.map(str::to_string)
}

pub(super) fn model_problem(image_id: u32, name: &str, p: NameProblem) -> ImportProblem {
    let name = name.to_string();
    match p {
        NameProblem::Unmappable(reason) => ImportProblem::ModelNameUnmappable {
            image_id,
            name,
            reason,
        },
        NameProblem::NotInDataset(mapped) => ImportProblem::ModelImageNotInDataset {
            image_id,
            name,
            mapped,
        },
        NameProblem::TestFrame(frame_id) => ImportProblem::ModelImageIsTestFrame {
            image_id,
            name,
            frame_id,
        },
        NameProblem::Duplicate(mapped, first) => ImportProblem::DuplicateModelName {
            mapped,
            first_image_id: first,
            second_image_id: image_id,
        },
    }
}

pub(super) fn limap_problem(limap_image_id: u32, name: &str, p: NameProblem) -> ImportProblem {
    let name = name.to_string();
    match p {
        NameProblem::Unmappable(reason) => ImportProblem::LimapNameUnmappable {
            limap_image_id,
            name,
            reason,
        },
        NameProblem::NotInDataset(mapped) => ImportProblem::LimapImageNotInDataset {
            limap_image_id,
            name,
            mapped,
        },
        NameProblem::TestFrame(frame_id) => ImportProblem::LimapImageIsTestFrame {
            limap_image_id,
            name,
            frame_id,
        },
        NameProblem::Duplicate(mapped, first) => ImportProblem::DuplicateLimapName {
            mapped,
            first_limap_image_id: first,
            second_limap_image_id: limap_image_id,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geometry::{Camera, CameraModel, Pose};
    use std::path::PathBuf;

    fn frame(name: &str) -> Frame {
        Frame {
            id: 0,
            name: name.into(),
            path: PathBuf::from(name),
            split: Split::Train,
            camera: Camera::new(CameraModel::SimplePinhole, 4, 4, vec![2.0, 2.0, 2.0]).unwrap(),
            pose: Pose::identity(),
            depth_path: None,
            depth_hash: None,
            width: 4,
            height: 4,
            content_hash: String::new(),
        }
    }

    #[test]
    fn the_root_prefix_is_found_only_when_one_prefix_explains_every_name() {
        let frames = [frame("seq-01/a.png"), frame("seq-02/b.png")];
        let by_name: HashMap<&str, &Frame> = frames.iter().map(|f| (f.name.as_str(), f)).collect();
        let root = |names: &[&str]| limap_root_prefix(names, &by_name);
        assert_eq!(
            root(&["/data/stairs/seq-01/a.png", "/data/stairs/seq-02/b.png"]),
            Some("/data/stairs/".into())
        );
        // Names that join as they are: nothing to strip.
        assert_eq!(root(&["seq-01/a.png", "seq-02/b.png"]), None);
        // Two roots, a name outside the dataset, a root without a `/` before the name.
        assert_eq!(root(&["/x/seq-01/a.png", "/y/seq-02/b.png"]), None);
        assert_eq!(root(&["/data/seq-01/a.png", "/data/seq-03/c.png"]), None);
        assert_eq!(root(&["/dataseq-01/a.png"]), None);
        assert_eq!(root(&[]), None);
        // Two prefixes that both work: ambiguous, so none.
        let frames = [frame("a.png"), frame("s/a.png")];
        let by_name: HashMap<&str, &Frame> = frames.iter().map(|f| (f.name.as_str(), f)).collect();
        assert_eq!(limap_root_prefix(&["/r/s/a.png"], &by_name), None);
    }
}
