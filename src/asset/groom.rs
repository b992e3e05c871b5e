//! `HairGroom`: guide strands from a `*.hair.xml` file (format: `docs/formats.md`).

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext};
use bevy::prelude::*;

use super::error::{HairAssetError, Locator, parse_document, parse_finite, read_header, read_text};

/// Most strands a groom may have. A file with more is refused (a hostile file cannot exhaust
/// memory).
pub const MAX_STRANDS: usize = 1_000_000;
/// Most particles one strand may have.
pub const MAX_PARTICLES_PER_STRAND: usize = 256;
/// Most particles a whole groom may have.
pub const MAX_PARTICLES: usize = 8_000_000;
/// Shortest allowed segment between consecutive particles, in metres after scaling.
pub const MIN_SEGMENT_LENGTH: f32 = 1e-6;

/// Guide strands in bone space, in metres, root first. Loaded from `*.hair.xml`.
#[derive(Asset, TypePath, Clone, Debug, PartialEq)]
pub struct HairGroom {
    /// The bone the positions are relative to (empty: the entity the hair is attached to).
    pub bone: String,
    /// Every strand's particles, strand after strand.
    pub points: Vec<Vec3>,
    /// Strand `i` is `points[offsets[i]..offsets[i + 1]]`; one more entry than strands.
    pub offsets: Vec<u32>,
}

impl HairGroom {
    /// Builds a groom from strands, checking them like the loader does.
    pub fn from_strands(
        bone: impl Into<String>,
        strands: impl IntoIterator<Item = Vec<Vec3>>,
    ) -> Result<Self, HairAssetError> {
        let mut groom = Self {
            bone: bone.into(),
            points: Vec::new(),
            offsets: vec![0],
        };
        for (i, strand) in strands.into_iter().enumerate() {
            check_strand(&strand, i).map_err(|m| super::error::whole_file("<code>", m))?;
            groom.points.extend(strand);
            groom.offsets.push(groom.points.len() as u32);
        }
        if groom.strand_count() == 0 {
            return Err(super::error::whole_file(
                "<code>",
                "a groom needs at least one strand",
            ));
        }
        Ok(groom)
    }

    /// Number of strands.
    pub fn strand_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Particles of strand `i`, root first.
    pub fn strand(&self, i: usize) -> &[Vec3] {
        &self.points[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// All strands in order.
    pub fn strands(&self) -> impl ExactSizeIterator<Item = &[Vec3]> + '_ {
        (0..self.strand_count()).map(|i| self.strand(i))
    }

    /// `true` when `other` has the same number of strands and particles per strand.
    pub fn same_topology(&self, other: &HairGroom) -> bool {
        self.offsets == other.offsets
    }
}

/// Checks particle count, finiteness and segment lengths of one strand.
fn check_strand(strand: &[Vec3], index: usize) -> Result<(), String> {
    if strand.len() < 2 {
        return Err(format!(
            "strand {index} has {} particle(s); a strand needs at least 2",
            strand.len()
        ));
    }
    if strand.len() > MAX_PARTICLES_PER_STRAND {
        return Err(format!(
            "strand {index} has {} particles; the limit is {MAX_PARTICLES_PER_STRAND}",
            strand.len()
        ));
    }
    for (j, w) in strand.windows(2).enumerate() {
        if !w[0].is_finite() || !w[1].is_finite() {
            return Err(format!(
                "strand {index}, particle {j}: coordinate is not finite"
            ));
        }
        let len = w[0].distance(w[1]);
        if len.is_nan() || len < MIN_SEGMENT_LENGTH {
            return Err(format!(
                "strand {index}: particles {j} and {} coincide (segment length {len:e} m); \
                 the minimum is {MIN_SEGMENT_LENGTH:e} m",
                j + 1
            ));
        }
    }
    Ok(())
}

/// Parses the text of a `*.hair.xml` file. `file` names it in errors.
pub fn parse_groom(file: &str, input: &str) -> Result<HairGroom, HairAssetError> {
    let doc = parse_document(file, input)?;
    let loc = Locator {
        file,
        doc: &doc,
        input,
    };
    let root = doc.root_element();
    let header = read_header(&loc, root, "groom")?;
    let inv_scale = 1.0 / header.scale;
    let mut groom = HairGroom {
        bone: header.bone,
        points: Vec::new(),
        offsets: vec![0],
    };
    let mut strand = Vec::with_capacity(16);
    for node in root.children().filter(|n| n.has_tag_name("strand")) {
        let index = groom.strand_count();
        if index >= MAX_STRANDS {
            return Err(loc.node(node, format!("more than {MAX_STRANDS} strands")));
        }
        strand.clear();
        let text = node.text().unwrap_or("");
        let mut numbers = text.split_ascii_whitespace();
        while let Some(x) = numbers.next() {
            let mut coord = [0.0f32; 3];
            for (k, token) in [Some(x), numbers.next(), numbers.next()]
                .into_iter()
                .enumerate()
            {
                let Some(token) = token else {
                    return Err(loc.node(
                        node,
                        format!(
                            "strand {index}: {} numbers is not a multiple of 3 (x y z per particle)",
                            strand.len() * 3 + k
                        ),
                    ));
                };
                coord[k] = parse_finite(token).map_err(|why| {
                    loc.slice(
                        token,
                        node,
                        format!(
                            "strand {index}, particle {}: {token:?}: {why}",
                            strand.len()
                        ),
                    )
                })?;
            }
            if strand.len() == MAX_PARTICLES_PER_STRAND {
                return Err(loc.node(
                    node,
                    format!("strand {index} has more than {MAX_PARTICLES_PER_STRAND} particles"),
                ));
            }
            strand.push(Vec3::from_array(coord) * inv_scale);
        }
        check_strand(&strand, index).map_err(|m| loc.node(node, m))?;
        if groom.points.len() + strand.len() > MAX_PARTICLES {
            return Err(loc.node(node, format!("more than {MAX_PARTICLES} particles in all")));
        }
        groom.points.extend_from_slice(&strand);
        groom.offsets.push(groom.points.len() as u32);
    }
    if groom.strand_count() == 0 {
        return Err(loc.node(root, "the groom has no <strand> elements"));
    }
    Ok(groom)
}

/// Loads [`HairGroom`] assets from `*.hair.xml`.
#[derive(Default, TypePath)]
pub struct HairGroomLoader;

impl AssetLoader for HairGroomLoader {
    type Asset = HairGroom;
    type Settings = ();
    type Error = HairAssetError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        load_context: &mut LoadContext<'_>,
    ) -> Result<HairGroom, HairAssetError> {
        let file = load_context.path().to_string();
        let text = read_text(reader, &file).await?;
        parse_groom(&file, &text)
    }

    fn extensions(&self) -> &[&str] {
        &["hair.xml"]
    }
}
