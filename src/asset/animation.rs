//! `HairAnimation`: keyframe styles from a `*.hairanim.xml` file (format: `docs/formats.md`).
//!
//! The thesis crashed when a keyframe groom did not match the base; here loading fails with an
//! error naming the keyframe, the strand and both particle counts, and nothing else is affected.

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, AssetPath, LoadContext};
use bevy::curve::cubic_splines::{CubicCardinalSpline, CubicCurve, CubicGenerator};
use bevy::prelude::*;

use super::error::HairAssetError;
use super::fields::{BYTES_PER_ELEMENT, float_attr, float_attr_or, read_text};
use super::groom::{
    ATTRIBUTES_PER_ELEMENT, GroomLoaderSettings, HEADER_BYTES, HairGroom, MARKUP_ALLOWANCE,
    MAX_PARTICLES,
};
use super::reader::Xml;

/// Most keyframes an animation may have.
pub const MAX_KEYS: usize = 256;
/// Most particles all keys of one animation may bring in together (keys x particles per key):
/// the largest groom's worth, 24 MB of positions. Each key's groom is loaded with what is left
/// of this budget, so the loader stops before storing more.
pub const MAX_ANIMATION_PARTICLES: usize = MAX_PARTICLES;
/// Largest animation file the loader reads: [`HEADER_BYTES`](super::HEADER_BYTES) plus 256
/// bytes per key.
pub const ANIMATION_BYTE_LIMIT: usize = HEADER_BYTES + MAX_KEYS * BYTES_PER_ELEMENT;
/// Longest key path, in bytes.
pub const MAX_KEY_PATH: usize = 200;

/// One keyframe: a full groom pose at a time.
#[derive(Clone, Debug, PartialEq)]
pub struct HairKeyframe {
    /// Seconds from the start of the animation.
    pub time: f32,
    /// The style at that time; same topology as every other key.
    pub pose: HairGroom,
}

/// Keyframe styles that anchors follow, interpolated with a Catmull-Rom spline over time.
#[derive(Asset, TypePath, Clone, Debug)]
pub struct HairAnimation {
    /// Keys in increasing time; at least one; all with the topology of the first.
    pub keys: Vec<HairKeyframe>,
    /// Whether the animation repeats.
    pub looping: bool,
    /// Loop period in seconds (greater than the last key's time).
    pub duration: f32,
    /// Catmull-Rom basis from bevy_math: evaluated on its middle segment, it gives the weights of
    /// four consecutive keys.
    basis: CubicCurve<Vec4>,
}

/// A key written in a `.hairanim.xml`, before its groom is loaded.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyReference {
    /// Seconds.
    pub time: f32,
    /// Groom path as written (relative to the animation file).
    pub groom: String,
    /// Where the `<key>` element is, for errors.
    pub line: u32,
    /// Column of the `<key>` element.
    pub column: u32,
}

/// The parsed text of a `.hairanim.xml` file.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimationDescription {
    /// The keys, in file order (times strictly increasing).
    pub keys: Vec<KeyReference>,
    /// `loop` attribute.
    pub looping: bool,
    /// Loop period: `duration`, or the last key's time plus the last gap.
    pub duration: f32,
}

/// Parses the text of a `*.hairanim.xml` file (without loading its grooms).
pub fn parse_animation(file: &str, input: &str) -> Result<AnimationDescription, HairAssetError> {
    let mut xml = Xml::new(
        file,
        input,
        (
            2 * MAX_KEYS + MARKUP_ALLOWANCE,
            ATTRIBUTES_PER_ELEMENT * MAX_KEYS + MARKUP_ALLOWANCE,
        ),
    );
    let root = xml.root()?;
    if root.name != "hairanim" {
        return Err(xml.error(
            root.offset,
            format!("expected a <hairanim> root element, found <{}>", root.name),
        ));
    }
    match xml.attr("version") {
        Some(v) if v.value == "1" => {}
        Some(v) => {
            return Err(xml.error(
                v.offset,
                format!(
                    "unsupported format version {:?} (this crate reads version 1)",
                    v.value
                ),
            ));
        }
        None => return Err(xml.error(root.offset, "<hairanim> needs version=\"1\"")),
    }
    let looping = match xml.attr("loop") {
        None => true,
        Some(a) => match a.value.as_ref() {
            "true" | "1" => true,
            "false" | "0" => false,
            other => {
                return Err(xml.error(
                    a.offset,
                    format!("loop must be true or false, found {other:?}"),
                ));
            }
        },
    };
    let duration_attr = float_attr_or(&xml, &root, "duration", f32::NAN)?;
    let duration_at = xml.attr("duration").map_or(root.offset, |a| a.offset);
    let mut keys: Vec<KeyReference> = Vec::new();
    while let Some(node) = xml.next_child(
        &root,
        "key",
        "text inside <hairanim>; keys are <key .../> elements",
    )? {
        if keys.len() >= MAX_KEYS {
            return Err(xml.error(node.offset, format!("more than {MAX_KEYS} keys")));
        }
        let time = float_attr(&xml, &node, "time")?;
        if time < 0.0 {
            return Err(xml.error(node.offset, format!("key time must be >= 0, found {time}")));
        }
        if let Some(prev) = keys.last()
            && time <= prev.time
        {
            return Err(xml.error(
                node.offset,
                format!("key times must increase: {time} follows {}", prev.time),
            ));
        }
        let groom = match xml.attr("groom") {
            None => return Err(xml.error(node.offset, "<key> is missing the attribute `groom`")),
            Some(g) if g.value.trim().is_empty() => {
                return Err(xml.error(
                    g.offset,
                    "<key> attribute `groom` is blank; it names a .hair.xml file",
                ));
            }
            Some(g) if g.value.len() > MAX_KEY_PATH => {
                return Err(xml.error(
                    g.offset,
                    format!("<key> attribute `groom` is longer than {MAX_KEY_PATH} bytes"),
                ));
            }
            Some(g) => g.value.to_string(),
        };
        let (line, column) = super::prescan::line_column(input, node.offset);
        xml.skip(&node)?;
        keys.push(KeyReference {
            time,
            groom,
            line,
            column,
        });
    }
    xml.finish()?;
    let Some(last) = keys.last() else {
        return Err(xml.error(root.offset, "the animation has no <key> elements"));
    };
    let default_duration = match keys.len() {
        1 => last.time + 1.0,
        n => last.time + (last.time - keys[n - 2].time),
    };
    let duration = if duration_attr.is_nan() {
        default_duration
    } else {
        duration_attr
    };
    if !duration.is_finite() || duration <= last.time {
        return Err(xml.error(
            duration_at,
            format!(
                "duration {duration} must be greater than the last key's time {}",
                last.time
            ),
        ));
    }
    Ok(AnimationDescription {
        keys,
        looping,
        duration,
    })
}

/// Checks a key's groom path and resolves it against the animation file: the result stays in
/// the animation's asset source, inside its root (Bevy's approved-path rule, checked here
/// because nested loads skip it), and names a `.hair.xml` file.
pub fn resolve_key_path(
    animation: &AssetPath<'_>,
    key: &str,
) -> Result<AssetPath<'static>, String> {
    let refuse = |why: &str| Err(format!("groom path {key:?} {why}"));
    if key.contains("://") {
        return refuse("names an asset source; keys must be paths relative to the animation file");
    }
    if key.starts_with('/') || key.starts_with('\\') || key.contains(':') {
        return refuse("is absolute; keys must be paths relative to the animation file");
    }
    if key.contains('\\') || key.contains('\0') || key.contains('#') {
        return refuse("may not contain `\\`, `#` or NUL; use `/` between folders");
    }
    if !key.ends_with(".hair.xml") {
        return refuse("does not name a .hair.xml groom");
    }
    let resolved = animation
        .resolve_embed_str(key)
        .map_err(|e| format!("groom path {key:?} is not a valid asset path: {e}"))?;
    if resolved.is_unapproved() || animation.is_unapproved() {
        return refuse("leads outside the asset folder; keys must stay inside it");
    }
    if resolved.source() != animation.source() {
        return refuse("leads to another asset source");
    }
    // `resolve_embed` drops `..` components that climb above the root instead of failing: a
    // key that climbs more folders than the animation sits in has escaped.
    let depth = animation.path().components().count().saturating_sub(1);
    let mut level: isize = depth as isize;
    for part in std::path::Path::new(key).components() {
        match part {
            std::path::Component::ParentDir => level -= 1,
            std::path::Component::Normal(_) => level += 1,
            _ => {}
        }
        if level < 0 {
            return refuse("leads outside the asset folder; keys must stay inside it");
        }
    }
    Ok(resolved)
}

impl HairAnimation {
    /// Builds an animation from poses, checking that every pose matches the first one's topology.
    pub fn new(
        keys: Vec<HairKeyframe>,
        looping: bool,
        duration: f32,
    ) -> Result<Self, HairAssetError> {
        let Some(first) = keys.first() else {
            return Err(HairAssetError::in_code(
                "an animation needs at least one key",
            ));
        };
        for (i, key) in keys.iter().enumerate().skip(1) {
            if let Some(msg) = topology_mismatch(&first.pose, &key.pose) {
                return Err(HairAssetError::in_code(format!("key {i}: {msg}")));
            }
            if key.time <= keys[i - 1].time || !key.time.is_finite() {
                return Err(HairAssetError::in_code(format!(
                    "key {i}: times must increase"
                )));
            }
        }
        let last = keys.last().map_or(0.0, |k| k.time);
        let duration = if duration.is_finite() && duration > last {
            duration
        } else {
            last + 1.0
        };
        Ok(Self {
            keys,
            looping,
            duration,
            basis: catmull_rom_basis(),
        })
    }

    /// The pose at `time` seconds, written into `out` (one position per particle, bone space).
    /// `out` must have as many entries as a key has particles.
    pub fn sample(&self, time: f32, out: &mut [Vec3]) {
        let mut weights = [(0usize, 0.0f32); 4];
        let n = self.weights(time, &mut weights);
        out.fill(Vec3::ZERO);
        for &(key, w) in &weights[..n] {
            if w == 0.0 {
                continue;
            }
            for (o, p) in out.iter_mut().zip(&self.keys[key].pose.points) {
                *o += *p * w;
            }
        }
    }

    /// Keys and weights whose sum is the pose at `time`; returns how many entries of `out` are
    /// used (1 to 4). Weights sum to 1.
    pub fn weights(&self, time: f32, out: &mut [(usize, f32); 4]) -> usize {
        let n = self.keys.len();
        let time = if time.is_finite() { time } else { 0.0 };
        if n == 1 {
            out[0] = (0, 1.0);
            return 1;
        }
        let t = if self.looping {
            time.rem_euclid(self.duration)
        } else {
            time.clamp(self.keys[0].time, self.keys[n - 1].time)
        };
        let first = self.keys[0].time;
        // Segment `i` runs from key i to key i+1; with looping, the last one wraps to key 0.
        let (i, t0, t1) = if t < first {
            // Looping and before the first key: the wrap segment, shifted back one period.
            (n - 1, self.keys[n - 1].time - self.duration, first)
        } else {
            let i = self.keys.partition_point(|k| k.time <= t).saturating_sub(1);
            let t1 = if i + 1 < n {
                self.keys[i + 1].time
            } else {
                self.duration + first
            };
            (i, self.keys[i].time, t1)
        };
        if !self.looping && i + 1 >= n {
            out[0] = (n - 1, 1.0);
            return 1;
        }
        let u = ((t - t0) / (t1 - t0).max(1e-6)).clamp(0.0, 1.0);
        let w = self.basis.position(1.0 + u).to_array();
        let idx = |k: isize| -> Option<usize> {
            let j = i as isize + k;
            if self.looping {
                Some(j.rem_euclid(n as isize) as usize)
            } else if (0..n as isize).contains(&j) {
                Some(j as usize)
            } else {
                None
            }
        };
        // Control points p(-1), p(0), p(1), p(2) around segment i. Without looping, a missing end
        // is mirrored like bevy_math does: p(-1) = 2 p(0) - p(1), p(2) = 2 p(1) - p(0).
        let mut acc = [(i, 0.0f32), (i, 0.0), (i, 0.0), (i, 0.0)];
        let mut add = |slot: usize, key: usize, weight: f32| {
            acc[slot].0 = key;
            acc[slot].1 += weight;
        };
        let (k0, k1) = (idx(0).unwrap_or(i), idx(1).unwrap_or(i));
        add(1, k0, w[1]);
        add(2, k1, w[2]);
        match idx(-1) {
            Some(k) => add(0, k, w[0]),
            None => {
                add(1, k0, 2.0 * w[0]);
                add(2, k1, -w[0]);
            }
        }
        match idx(2) {
            Some(k) => add(3, k, w[3]),
            None => {
                add(2, k1, 2.0 * w[3]);
                add(1, k0, -w[3]);
            }
        }
        *out = acc;
        4
    }

    /// The base pose (first key).
    pub fn base(&self) -> &HairGroom {
        &self.keys[0].pose
    }
}

fn catmull_rom_basis() -> CubicCurve<Vec4> {
    CubicCardinalSpline::new_catmull_rom([Vec4::X, Vec4::Y, Vec4::Z, Vec4::W])
        .to_curve()
        .expect("four control points are enough for a curve")
}

/// Describes how `pose` differs from `base` in topology, or `None` if they match.
fn topology_mismatch(base: &HairGroom, pose: &HairGroom) -> Option<String> {
    if base.strand_count() != pose.strand_count() {
        return Some(format!(
            "it has {} strands, the base groom has {}",
            pose.strand_count(),
            base.strand_count()
        ));
    }
    (0..base.strand_count()).find_map(|s| {
        let (a, b) = (base.strand(s).len(), pose.strand(s).len());
        (a != b).then(|| format!("strand {s} has {b} particles, the base groom has {a}"))
    })
}

/// Loads [`HairAnimation`] assets from `*.hairanim.xml`, loading every keyframe groom as a
/// dependency and refusing grooms whose topology differs from the first key's.
#[derive(Default, TypePath)]
pub struct HairAnimationLoader;

impl AssetLoader for HairAnimationLoader {
    type Asset = HairAnimation;
    type Settings = ();
    type Error = HairAssetError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        load_context: &mut LoadContext<'_>,
    ) -> Result<HairAnimation, HairAssetError> {
        let file = load_context.path().to_string();
        let text = read_text(reader, &file, ANIMATION_BYTE_LIMIT, "animation file").await?;
        let desc = parse_animation(&file, &text)?;
        let mut keys: Vec<HairKeyframe> = Vec::with_capacity(desc.keys.len());
        let mut particles = 0usize;
        for (i, key) in desc.keys.iter().enumerate() {
            let at = |message: String| HairAssetError {
                file: Some(file.clone()),
                line: key.line,
                column: key.column,
                message,
            };
            let path = resolve_key_path(load_context.path(), &key.groom)
                .map_err(|why| at(format!("key {i}: {why}")))?;
            let left = MAX_ANIMATION_PARTICLES - particles;
            let loaded = load_context
                .load_builder()
                .with_settings(move |s: &mut GroomLoaderSettings| {
                    s.max_particles = s.max_particles.min(left);
                })
                .load_value::<HairGroom>(path)
                .await
                .map_err(|e| {
                    at(format!(
                        "key {i}: could not load {:?} (this animation may bring in {left} more \
                         particles of its {MAX_ANIMATION_PARTICLES}): {e}",
                        key.groom
                    ))
                })?;
            let pose = loaded.take();
            particles += pose.points.len();
            if let Some(first) = keys.first()
                && let Some(msg) = topology_mismatch(&first.pose, &pose)
            {
                return Err(at(format!(
                    "key {i} ({}) does not match the first key ({}): {msg}",
                    key.groom, desc.keys[0].groom
                )));
            }
            keys.push(HairKeyframe {
                time: key.time,
                pose,
            });
        }
        HairAnimation::new(keys, desc.looping, desc.duration).map_err(|mut e| {
            e.file = Some(file.clone());
            e
        })
    }

    fn extensions(&self) -> &[&str] {
        &["hairanim.xml"]
    }
}
