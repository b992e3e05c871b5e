//! `HairGroom`: guide strands from a `*.hair.xml` file (format: `docs/formats.md`).

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext};
use bevy::prelude::*;

use serde::{Deserialize, Serialize};

use super::error::HairAssetError;
use super::fields::{MAX_COORDINATE, parse_finite, read_header, read_text, scaled};
use super::reader::{Item, Xml};

/// Most strands a groom may have (ten times a 10,000-strand groom). Counted while reading,
/// before anything is kept for them.
pub const MAX_STRANDS: usize = 100_000;
/// Most markup (elements, comments, processing instructions, CDATA sections) a groom file may
/// have: two a strand and room for a header, comments and later versions' elements. Counted
/// before the file is parsed, so the parser's tree never holds more.
pub const MAX_GROOM_MARKUP: usize = 2 * MAX_STRANDS + MARKUP_ALLOWANCE;
/// Most memory parsing one groom file takes beside its text, whatever the file (within
/// [`MAX_GROOM_MARKUP`] and the byte limit): the parser's tree of the largest file the limits
/// allow, and the positions kept. Measured by the hostile tests; `docs/formats.md`.
pub const GROOM_PARSE_MEMORY: usize = 80 << 20;
/// Attributes a collision shape or animation key may have, for the limit on a file's
/// attributes in all (a capsule has 7).
pub const ATTRIBUTES_PER_ELEMENT: usize = 8;
/// Markup every hair file may have beside what its elements count: the XML declaration,
/// comments, later versions' elements.
pub const MARKUP_ALLOWANCE: usize = 1024;
/// Most particles one strand may have.
pub const MAX_PARTICLES_PER_STRAND: usize = 256;
/// Most particles a whole groom may have (24 MB of positions). Counted while reading, before
/// anything is kept for them.
pub const MAX_PARTICLES: usize = 2_000_000;
/// Bytes a groom file may take per particle: three numbers of up to 20 bytes each with their
/// separators (the add-on writes at most 49 per particle), so a file within [`MAX_PARTICLES`] fits.
pub const GROOM_BYTES_PER_PARTICLE: usize = 60;
/// Bytes a groom file may take per strand for its tags and indentation.
pub const GROOM_BYTES_PER_STRAND: usize = 24;
/// Bytes a hair file may take for its header, comments and closing tag.
pub const HEADER_BYTES: usize = 64 * 1024;

/// Largest groom file the loader reads when it may bring in at most `max_particles` particles:
/// [`HEADER_BYTES`] + `max_particles` x [`GROOM_BYTES_PER_PARTICLE`] + one strand per two
/// particles x [`GROOM_BYTES_PER_STRAND`] (144 MB at [`MAX_PARTICLES`]). Reading stops there.
pub const fn groom_byte_limit(max_particles: usize) -> usize {
    HEADER_BYTES
        + max_particles * GROOM_BYTES_PER_PARTICLE
        + max_particles.div_ceil(2) * GROOM_BYTES_PER_STRAND
}

/// Settings of [`HairGroomLoader`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroomLoaderSettings {
    /// Most particles this load may bring in; at most [`MAX_PARTICLES`]. The animation loader
    /// lowers it to what is left of its budget for each key.
    /// Default: [`MAX_PARTICLES`].
    pub max_particles: usize,
}

impl Default for GroomLoaderSettings {
    fn default() -> Self {
        Self {
            max_particles: MAX_PARTICLES,
        }
    }
}
/// Shortest allowed segment between consecutive particles, in metres after scaling.
pub const MIN_SEGMENT_LENGTH: f32 = 1e-6;

/// Guide strands in bone space, in metres, root first. Loaded from `*.hair.xml`.
#[derive(Asset, TypePath, Clone, Debug, PartialEq)]
pub struct HairGroom {
    /// The bone the positions are relative to (empty: the entity the hair is attached to).
    pub bone: String,
    /// Metres one unit of the bone's frame was in the file's source (`bone_scale`; the add-on
    /// writes it for scaled rigs, e.g. `0.01` for Mixamo). The plugin warns when the bone it
    /// hangs on has another scale: the hair would come out larger or smaller than authored.
    pub bone_scale: Option<f32>,
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
            bone_scale: None,
            points: Vec::new(),
            offsets: vec![0],
        };
        for (i, strand) in strands.into_iter().enumerate() {
            check_strand(&strand, i).map_err(HairAssetError::in_code)?;
            if groom.points.len() + strand.len() > MAX_PARTICLES {
                return Err(HairAssetError::in_code(format!(
                    "more than {MAX_PARTICLES} particles in all"
                )));
            }
            groom.points.extend(strand);
            groom.offsets.push(groom.points.len() as u32);
        }
        if groom.strand_count() == 0 {
            return Err(HairAssetError::in_code("a groom needs at least one strand"));
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
    for (j, p) in strand.iter().enumerate() {
        if !p.is_finite() || p.abs().max_element() > super::fields::MAX_COORDINATE {
            return Err(format!(
                "strand {index}, particle {j}: coordinate {p} is not finite or farther than {} m \
                 from the bone",
                super::fields::MAX_COORDINATE
            ));
        }
    }
    for (j, w) in strand.windows(2).enumerate() {
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
    parse_groom_within(file, input, MAX_PARTICLES)
}

/// Parses a groom that may have at most `max_particles` particles (capped at [`MAX_PARTICLES`]).
/// Counts are checked before anything is stored, so a refused file never costs more than the
/// positions allowed.
pub fn parse_groom_within(
    file: &str,
    input: &str,
    max_particles: usize,
) -> Result<HairGroom, HairAssetError> {
    let max_particles = max_particles.min(MAX_PARTICLES);
    let mut xml = Xml::new(file, input, (MAX_GROOM_MARKUP, MAX_GROOM_MARKUP));
    let root = xml.root()?;
    let header = read_header(&xml, &root, "groom")?;
    let mut groom = HairGroom {
        bone: header.bone,
        bone_scale: header.bone_scale,
        points: Vec::new(),
        offsets: vec![0],
    };
    let mut strand: Vec<Vec3> = Vec::with_capacity(16);
    // The number (or partial particle) being read, carried across text pieces of one strand.
    let mut coord = [0.0f32; 3];
    while let Some(element) = xml.next_child(
        &root,
        "strand",
        "text outside <strand>; numbers belong inside a <strand> element",
    )? {
        let index = groom.strand_count();
        if index >= MAX_STRANDS {
            return Err(xml.error(element.offset, format!("more than {MAX_STRANDS} strands")));
        }
        strand.clear();
        let mut k = 0;
        loop {
            let (text, offset) = match xml.next_in(&element)? {
                Item::End => break,
                Item::Text { text, offset } => (text, offset),
                Item::Markup { what, offset } => {
                    return Err(xml.error(
                        offset,
                        format!(
                            "strand {index}: {what} inside <strand>; a strand holds only numbers"
                        ),
                    ));
                }
                Item::Element(e) => {
                    return Err(xml.error(
                        e.offset,
                        format!(
                            "strand {index}: element <{}> inside <strand>; a strand holds only \
                             numbers",
                            e.name
                        ),
                    ));
                }
            };
            for token in text.split_ascii_whitespace() {
                let particle = strand.len();
                let raw = parse_finite(token).map_err(|why| {
                    xml.error_at_slice(
                        token,
                        offset,
                        format!("strand {index}, particle {particle}: {token:?}: {why}"),
                    )
                })?;
                coord[k] = raw;
                k += 1;
                if k < 3 {
                    continue;
                }
                k = 0;
                if particle == MAX_PARTICLES_PER_STRAND {
                    return Err(xml.error(
                        element.offset,
                        format!(
                            "strand {index} has more than {MAX_PARTICLES_PER_STRAND} particles"
                        ),
                    ));
                }
                if groom.points.len() + particle >= max_particles {
                    return Err(xml.error(
                        element.offset,
                        format!("more than {max_particles} particles in all"),
                    ));
                }
                let p = Vec3::from_array(coord) / header.scale;
                if !(p.is_finite() && p.abs().max_element() <= MAX_COORDINATE) {
                    // Name the coordinate that broke the rule (only now build the message).
                    for (axis, raw) in coord.into_iter().enumerate() {
                        scaled(
                            &xml,
                            xml.offset_of(token, offset),
                            raw,
                            header.scale,
                            || {
                                format!(
                                    "strand {index}, particle {particle}, {}",
                                    ["x", "y", "z"][axis]
                                )
                            },
                        )?;
                    }
                }
                strand.push(p);
            }
        }
        if k != 0 {
            return Err(xml.error(
                element.offset,
                format!(
                    "strand {index}: {} numbers is not a multiple of 3 (x y z per particle)",
                    strand.len() * 3 + k
                ),
            ));
        }
        check_strand(&strand, index).map_err(|m| xml.error(element.offset, m))?;
        groom.points.extend_from_slice(&strand);
        groom.offsets.push(groom.points.len() as u32);
    }
    xml.finish()?;
    if groom.strand_count() == 0 {
        return Err(xml.error(root.offset, "the groom has no <strand> elements"));
    }
    groom.points.shrink_to_fit();
    groom.offsets.shrink_to_fit();
    Ok(groom)
}

/// Loads [`HairGroom`] assets from `*.hair.xml`.
#[derive(Default, TypePath)]
pub struct HairGroomLoader;

impl AssetLoader for HairGroomLoader {
    type Asset = HairGroom;
    type Settings = GroomLoaderSettings;
    type Error = HairAssetError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        settings: &GroomLoaderSettings,
        load_context: &mut LoadContext<'_>,
    ) -> Result<HairGroom, HairAssetError> {
        let file = load_context.path().to_string();
        let max = settings.max_particles.min(MAX_PARTICLES);
        let text = read_text(reader, &file, groom_byte_limit(max), "groom").await?;
        parse_groom_within(&file, &text, max)
    }

    fn extensions(&self) -> &[&str] {
        &["hair.xml"]
    }
}
