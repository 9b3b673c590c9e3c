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
