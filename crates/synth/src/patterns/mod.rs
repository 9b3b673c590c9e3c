//! Texture recipes. Each paints one quad's texture from its own seed and returns the
//! straight intensity steps it drew, as segments in the quad's local metres, so that
//! the scene can list them as exact 3D edges.
//!
//! Design rules that keep those edge lists honest:
//! - straight steps come only from flat-coloured rectangles and stripes whose colours
//!   differ in luma by at least [`MIN_CONTRAST`]; they never overlap one another;
//! - everything SIFT is meant to find (value noise, ellipses, rings, dots) is curved and
//!   kept a margin away from the listed steps, so it never breaks an edge;
//! - a final low-amplitude noise modulates every texel multiplicatively, which changes
//!   no edge position.
//!
//! This file holds the recipes' list ([`Material`]) and [`paint`], which runs one; the
//! painter's tools are in `painter.rs` and the recipes in `room.rs` (wallpaper, ceiling,
//! floor tiles, rug), `wall_art.rs` (posters and framed pictures) and `objects.rs` (wood,
//! cardboard, books, doors, plain colours).

mod objects;
mod painter;
mod room;
mod wall_art;

pub use painter::LocalEdge;

use super::texture::{Canvas, Rect, Rgb, Texture};
use painter::Painter;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Minimum luma difference (of the flat colours, before shading) of a listed texture edge.
pub const MIN_CONTRAST: f32 = 0.12;

/// Which recipe paints a quad.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    Wallpaper {
        palette: u8,
    },
    Ceiling,
    FloorTiles,
    Rug,
    PosterMondrian,
    PosterStripes,
    /// Front of a picture frame: moulding of the given width, a mat, a photo.
    Picture {
        moulding: f64,
    },
    /// Wood; `grain_along_a` orients the streaks along the quad's `u` axis.
    Wood {
        tone: Rgb,
        grain_along_a: bool,
    },
    Cardboard {
        tone: Rgb,
        label: bool,
    },
    BookSpine {
        colour: Rgb,
    },
    BookCover {
        colour: Rgb,
    },
    Pages,
    Door {
        colour: Rgb,
    },
    Plain {
        colour: Rgb,
    },
}

/// Paints `material` on a quad of `size` metres at `rho` texels per metre.
pub fn paint(
    material: &Material,
    size: [f64; 2],
    rho: f64,
    seed: u64,
) -> (Texture, Vec<LocalEdge>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut p = Painter {
        canvas: Canvas::new(size, rho, [0.5; 3]),
        size,
        edges: Vec::new(),
        seed,
    };
    match material {
        Material::Wallpaper { palette } => p.wallpaper(&mut rng, *palette),
        Material::Ceiling => p.ceiling(&mut rng),
        Material::FloorTiles => p.floor_tiles(&mut rng),
        Material::Rug => p.rug(&mut rng),
        Material::PosterMondrian => p.mondrian(&mut rng),
        Material::PosterStripes => p.stripes(&mut rng),
        Material::Picture { moulding } => p.picture(&mut rng, *moulding),
        Material::Wood {
            tone,
            grain_along_a,
        } => p.wood(
            &mut rng,
            *tone,
            *grain_along_a,
            Rect::new(0.0, 0.0, size[0], size[1]),
        ),
        Material::Cardboard { tone, label } => p.cardboard(&mut rng, *tone, *label),
        Material::BookSpine { colour } => p.book_spine(&mut rng, *colour),
        Material::BookCover { colour } => p.plain(&mut rng, *colour, 0.12),
        Material::Pages => p.plain(&mut rng, [0.93, 0.9, 0.82], 0.06),
        Material::Door { colour } => p.door(&mut rng, *colour),
        Material::Plain { colour } => p.plain(&mut rng, *colour, 0.1),
    }
    p.grain();
    let edges = p
        .edges
        .into_iter()
        .filter(|e| {
            let l = ((e.b[0] - e.a[0]).powi(2) + (e.b[1] - e.a[1]).powi(2)).sqrt();
            l >= 0.01 && e.contrast >= MIN_CONTRAST
        })
        .collect();
    (p.canvas.finish(), edges)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paint_is_deterministic_and_edges_are_steps() {
        for m in [
            Material::PosterMondrian,
            Material::PosterStripes,
            Material::FloorTiles,
            Material::Picture { moulding: 0.04 },
        ] {
            let (t1, e1) = paint(&m, [0.6, 0.8], 400.0, 5);
            let (t2, e2) = paint(&m, [0.6, 0.8], 400.0, 5);
            assert_eq!(e1, e2);
            assert_eq!(t1.texel(100, 100), t2.texel(100, 100));
            assert!(!e1.is_empty(), "{m:?} drew no edges");
        }
    }
}
