//! Level of detail: hair small on screen gets fewer tube rings and sides, and at the smallest
//! level no specular quads.
//!
//! Each frame, with culling (see `culling`), the hair's bounds are projected by every active
//! 3D camera; the largest height on screen, in pixels, picks the level:
//!
//! | level | screen height (default thresholds) | rings | sides | specular quads |
//! |---|---|---|---|---|
//! | 0 | 240 px and more | the settings' | the settings' | the settings' |
//! | 1 | 80 to 240 px | three quarters (at least 4) | the settings' | half the samples |
//! | 2 | 40 to 80 px | half (at least 3) | three quarters (at least 3) | none |
//! | 3 | under 40 px | a quarter (at least 3) | half (at least 3) | none |
//!
//! Whatever the level, a tube never has more sides than its strands' width on screen needs: the
//! fewest whose polygon's outline stays within [`HairLod::silhouette_error`] pixels (default
//! half a pixel) of a round tube's, at least 3 (see [`sides_for_width`]). Strands 2 px wide
//! need 3 sides, 3 px wide 4, 8 px wide 7; strands wider than about 10 px keep the settings'
//! sides. The width is the thickest strand's, at the hair's nearest point to the camera. A hair
//! starts from the most sides and comes down only with the hysteresis below, so a still hair
//! has the sides of strands [`HairLod::hysteresis`] times wider than its own (2 px: 4 sides).
//!
//! Where half tubes hold (see [`HairLod::half_tubes`]), strands under
//! [`HairLod::ribbon_pixels`] (default 3 px) wide on screen are drawn as ribbons turned to the
//! camera: two triangles a segment with the round tube's outline.
//!
//! Going back up waits until the hair is [`HairLod::hysteresis`] times larger than the threshold
//! it went down at, so a hair at the edge does not flicker between levels. The steps are as
//! coarse as keeps a switch from showing: the test `lod_switches_move_the_silhouette_by_at_most_two_pixels`
//! renders a spiky hair at each threshold and finds 4 of 6,271 covered pixels changing at 240 px,
//! 15 of 703 at 80 px and 5 of 171 at 40 px (at most one of them a pixel of gap opening between
//! two strands, the rest within two pixels of the finer silhouette). Fewer sides at 240 px changed 108 pixels, a
//! quarter of the rings at 80 px 30. The screen height is the
//! bounding sphere's diameter, so a hair "240 px" tall covers less than that. The strokes
//! follow the tube (they are built from its edges), so they get cheaper with it.

use bevy::camera::primitives::Aabb;
use bevy::prelude::*;

use super::tube;

/// A hair's level-of-detail policy. A component on the [`Hair`](crate::sim::Hair) entity,
/// inserted with defaults when missing; switch it off for hair that must keep its resolution.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct HairLod {
    /// Lower the resolution of hair small on screen. Default: `true`.
    pub enabled: bool,
    /// Screen heights, in pixels, under which the hair drops to level 1, 2 and 3.
    /// Default: `[240.0, 80.0, 40.0]`.
    pub thresholds: [f32; 3],
    /// How much larger than a threshold the hair must grow to go back up a level. Clamped to
    /// `[1, 4]`. Default: `1.25`.
    pub hysteresis: f32,
    /// How far, in pixels, a tube's polygonal outline may lie inside a round tube's: the sides
    /// are the fewest that keep within it at the strands' width on screen (never more than the
    /// level's). `0` (or not finite) keeps the level's sides. Default: `0.5`.
    pub silhouette_error: f32,
    /// Draw only the half of each round tube the camera sees
    /// ([`TubeTopology::facing`](super::tube::TubeTopology::facing)): half the triangles, the
    /// same outline. Only where it holds: tubes built on the GPU, every strand's section
    /// [`Round`](super::LockSection::Round) at aspect 1, one active camera seeing the hair, the
    /// shadow cast by ribbons ([`HairShadowCaster`](super::HairShadowCaster)), not the tubes,
    /// and no texture around the tube ([`HairTubesClosed`](super::HairTubesClosed): surface
    /// hatching). Default: `true`.
    pub half_tubes: bool,
    /// Where half tubes hold, strands narrower than this on screen, in pixels, are drawn as
    /// flat ribbons turned to the camera
    /// ([`TubeTopology::ribbon`](super::tube::TubeTopology::ribbon)): the round tube's outline
    /// from two triangles a segment, shaded with normals that only approximate the tube's
    /// (unseen at that width). They turn back into half tubes once
    /// [`HairLod::hysteresis`] times wider. `0` turns them off. Default: `3.0`.
    pub ribbon_pixels: f32,
}

impl Default for HairLod {
    fn default() -> Self {
        Self {
            enabled: true,
            thresholds: [240.0, 80.0, 40.0],
            hysteresis: 1.25,
            silhouette_error: 0.5,
            half_tubes: true,
            ribbon_pixels: 3.0,
        }
    }
}

/// The level a hair is drawn at (0 = full, 3 = coarsest) and its height on screen last frame, in pixels
/// (largest over the active 3D cameras; 0 when no camera sees it).
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct HairLodLevel {
    /// 0 (full) to 3.
    pub level: u8,
    /// Height on screen, pixels.
    pub pixels: f32,
    /// The thickest strand's width on screen last frame, pixels, at the hair's nearest point
    /// (largest over the active 3D cameras; 0 when no camera sees it).
    pub strand_pixels: f32,
    /// The most sides that width needs ([`sides_for_width`]): `u8::MAX` when it needs more than a
    /// tube has, `0` before the first choice or with the rule off.
    pub sides: u8,
    /// Whether its strands are narrow enough for ribbons ([`HairLod::ribbon_pixels`]); they
    /// are drawn so where half tubes hold.
    pub ribbons: bool,
}

impl HairLod {
    /// The level for a hair `pixels` tall on screen that was at level `current`.
    pub fn level_for(&self, pixels: f32, current: u8) -> u8 {
        if !self.enabled || !pixels.is_finite() {
            return 0;
        }
        let up = self.up();
        // The level the size alone asks for.
        let wanted = self
            .thresholds
            .iter()
            .filter(|&&t| pixels < t)
            .count()
            .min(3) as u8;
        if wanted >= current {
            return wanted;
        }
        // Going up: only past the threshold times the hysteresis.
        let mut level = current;
        while level > wanted {
            let t = self.thresholds[usize::from(level) - 1];
            if pixels >= t * up {
                level -= 1;
            } else {
                break;
            }
        }
        level
    }

    /// How much past a switch a hair must grow to go back: the hysteresis, clamped.
    fn up(&self) -> f32 {
        if self.hysteresis.is_finite() {
            self.hysteresis.clamp(1.0, 4.0)
        } else {
            1.25
        }
    }

    /// The most sides for strands `width` pixels wide on screen whose limit was `current`
    /// (see [`HairLodLevel::sides`]), with the same hysteresis as the levels: more sides as soon
    /// as the width asks for them, fewer only once the width is [`HairLod::hysteresis`] times
    /// under what they need. `0` when the rule is off.
    pub fn sides_for(&self, width: f32, current: u8) -> u8 {
        let error = self.silhouette_error;
        if !self.enabled || !error.is_finite() || error <= 0.0 || !width.is_finite() {
            return 0;
        }
        let wanted = sides_for_width(width, error);
        let current = match current {
            // None chosen yet, or no limit: the most sides there are, so a new hair starts
            // with the sides it keeps (a hair whose strands are near a switch does not change
            // its mesh in its first frames).
            0 | u8::MAX => usize::MAX,
            n => usize::from(n),
        };
        // The limit in use asks for fewer: more sides now.
        if current <= wanted {
            return to_limit(wanted);
        }
        let up = self.up();
        // Fewer: only as few as a strand `up` times wider would need.
        to_limit(sides_for_width(width * up, error).min(current))
    }

    /// Whether strands `width` pixels wide on screen, drawn as ribbons (`current`) or not,
    /// are ribbons now: under [`HairLod::ribbon_pixels`] they become ribbons, and go back only
    /// at [`HairLod::hysteresis`] times it.
    pub fn ribbons_for(&self, width: f32, current: bool) -> bool {
        let limit = self.ribbon_pixels;
        if !self.enabled || !limit.is_finite() || limit <= 0.0 || !width.is_finite() {
            return false;
        }
        if current {
            width < limit * self.up()
        } else {
            width < limit
        }
    }
}

/// `sides` as a [`HairLodLevel::sides`] limit: `u8::MAX` (none) when past what a tube can have.
fn to_limit(sides: usize) -> u8 {
    if sides >= tube::MAX_SIDES {
        u8::MAX
    } else {
        sides as u8
    }
}

/// The fewest sides (3 to [`tube::MAX_SIDES`]) whose regular polygon, its corners on a circle
/// `width` pixels across, has its outline within `error` pixels of the circle's from any
/// direction: `r (1 - cos(pi / n)) <= error` for `r = width / 2`.
pub fn sides_for_width(width: f32, error: f32) -> usize {
    let r = width * 0.5;
    if r.is_nan() || r <= error {
        return tube::MIN_SIDES;
    }
    let half_angle = (1.0 - error / r).clamp(-1.0, 1.0).acos();
    if half_angle <= 0.0 {
        return tube::MAX_SIDES;
    }
    ((std::f32::consts::PI / half_angle).ceil() as usize).clamp(tube::MIN_SIDES, tube::MAX_SIDES)
}

/// Rings and sides of a tube of `rings` x `sides` at `level`.
pub fn lod_topology(rings: usize, sides: usize, level: u8) -> (usize, usize) {
    let (rings, sides) = match level {
        0 => (rings, sides),
        1 => ((rings * 3 / 4).max(4.min(rings)), sides),
        2 => (
            (rings / 2).max(3.min(rings)),
            (sides * 3 / 4).max(3.min(sides)),
        ),
        _ => ((rings / 4).max(3.min(rings)), (sides / 2).max(3.min(sides))),
    };
    (
        rings.clamp(tube::MIN_RINGS, tube::MAX_RINGS),
        sides.clamp(tube::MIN_SIDES, tube::MAX_SIDES),
    )
}

/// The height on screen, in pixels, of `bounds` seen by `camera` from `view` (the camera's
/// world transform): the bounding sphere's projected diameter. `None` when the camera has no
/// viewport size yet or the bounds are behind it.
pub fn screen_height(camera: &Camera, view: &GlobalTransform, bounds: &Aabb) -> Option<f32> {
    let height = camera.logical_viewport_size()?.y;
    let (clip_from_view, _, w) = project_centre(camera, view, bounds)?;
    let radius = Vec3::from(bounds.half_extents).length();
    Some(2.0 * radius * clip_from_view.y_axis.y / w * height * 0.5)
}

/// [`screen_height`], and the width on screen in pixels of `width` metres at the point of
/// `bounds` nearest the camera (infinite when the camera is inside them).
pub fn screen_height_and_width(
    camera: &Camera,
    view: &GlobalTransform,
    bounds: &Aabb,
    width: f32,
) -> Option<(f32, f32)> {
    let logical = camera.logical_viewport_size()?.y;
    let pixels = camera.physical_viewport_size()?.y as f32;
    let (clip_from_view, centre, w) = project_centre(camera, view, bounds)?;
    let scale = clip_from_view.y_axis.y * 0.5;
    let radius = Vec3::from(bounds.half_extents).length();
    let height = 2.0 * radius * scale / w * logical;
    // The nearest point: towards the camera (+Z in view space) by the bounding radius.
    let w_near = (clip_from_view * (centre + Vec3::Z * radius).extend(1.0)).w;
    if w_near.is_nan() || w_near <= 1e-6 {
        return Some((height, f32::INFINITY));
    }
    Some((height, width * scale / w_near * pixels))
}

/// The camera's projection, the bounds' centre in view space and its clip `w` (perspective: the
/// depth; orthographic: 1). `None` behind the camera.
fn project_centre(
    camera: &Camera,
    view: &GlobalTransform,
    bounds: &Aabb,
) -> Option<(Mat4, Vec3, f32)> {
    let clip_from_view = camera.clip_from_view();
    let centre = view
        .affine()
        .inverse()
        .transform_point3(Vec3::from(bounds.center));
    let w = (clip_from_view * centre.extend(1.0)).w;
    (!w.is_nan() && w > 1e-6).then_some((clip_from_view, centre, w))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::tube::{FrameReference, TubeParams, TubeScratch, TubeTopology, build_tube};

    /// Spiky strands on the upper half of a head of radius 0.1 at the origin.
    fn spiky(strands: usize, particles: usize) -> Vec<Vec<Vec3>> {
        crate::test_support::spiky_strands(strands, particles, 0.1, 0.15, 0.04)
    }

    /// Which pixels of a `w` x `h` image the tubes of `strands` at `rings` x `sides` cover,
    /// seen by a pinhole camera at `eye` looking down -Z with `focal` pixels of focal length.
    fn coverage(
        strands: &[Vec<Vec3>],
        rings: usize,
        sides: usize,
        eye: Vec3,
        focal: f32,
        (w, h): (usize, usize),
    ) -> Vec<bool> {
        let topology = TubeTopology::new(rings, sides);
        let n = topology.vertex_count();
        let (mut p, mut nrm) = (vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
        let mut scratch = TubeScratch::default();
        let mut mask = vec![false; w * h];
        for strand in strands {
            let params = TubeParams {
                radius: 0.016,
                taper: [-0.4, -0.5, 1.0],
                reference: FrameReference::from_direction(strand[1] - strand[0]),
                ..Default::default()
            };
            build_tube(
                &topology,
                strand,
                &params,
                &mut scratch,
                &mut p,
                &mut nrm,
                None,
            );
            let screen: Vec<Vec2> = p
                .iter()
                .map(|v| {
                    let q = Vec3::from_array(*v) - eye;
                    let depth = -q.z;
                    Vec2::new(
                        w as f32 * 0.5 + focal * q.x / depth,
                        h as f32 * 0.5 - focal * q.y / depth,
                    )
                })
                .collect();
            for t in topology.indices.chunks(3) {
                let [a, b, c] = [0, 1, 2].map(|i| screen[t[i] as usize]);
                let lo = a.min(b).min(c).floor().max(Vec2::ZERO);
                let hi = a
                    .max(b)
                    .max(c)
                    .ceil()
                    .min(Vec2::new(w as f32 - 1.0, h as f32 - 1.0));
                let edge = |p: Vec2, q: Vec2, x: Vec2| (q - p).perp_dot(x - p);
                for y in lo.y as usize..=hi.y as usize {
                    for x in lo.x as usize..=hi.x as usize {
                        let m = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                        let e = [edge(a, b, m), edge(b, c, m), edge(c, a, m)];
                        if e.iter().all(|&v| v >= 0.0) || e.iter().all(|&v| v <= 0.0) {
                            mask[y * w + x] = true;
                        }
                    }
                }
            }
        }
        mask
    }

    /// `mask` grown (`grow`) or shrunk by one pixel (8 neighbours).
    fn morph(mask: &[bool], (w, h): (usize, usize), grow: bool) -> Vec<bool> {
        let at = |x: i64, y: i64| {
            if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                false
            } else {
                mask[y as usize * w + x as usize]
            }
        };
        let mut out = vec![false; w * h];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let around = (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy)));
                let mut values = around.map(|(dx, dy)| at(x + dx, y + dy));
                out[y as usize * w + x as usize] = if grow {
                    values.any(|v| v)
                } else {
                    values.all(|v| v)
                };
            }
        }
        out
    }

    /// At each default threshold, seen from where the hair is exactly that tall
    /// on screen (720 px viewport, 45 degree field of view), the coarser level's silhouette lies
    /// within two pixels of the finer one's (every pixel it adds is within two of the finer
    /// coverage; of the pixels it drops, at most one is farther than two from its outside), and
    /// under 3% of the covered pixels change.
    #[test]
    fn lod_switches_move_the_silhouette_by_at_most_two_pixels() {
        let strands = spiky(60, 6);
        let (lo, hi) = strands.iter().flatten().fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let (lo, hi) = (lo - 0.016, hi + 0.016);
        let centre = (lo + hi) * 0.5;
        let radius = ((hi - lo) * 0.5).length();
        let height = 720.0;
        let focal = height * 0.5 / (std::f32::consts::FRAC_PI_4 * 0.5).tan();
        let lod = HairLod::default();
        for (level, threshold) in [
            (1u8, lod.thresholds[0]),
            (2, lod.thresholds[1]),
            (3, lod.thresholds[2]),
        ] {
            // `screen_height`'s measure: the bounding sphere's diameter, 2 r focal / d.
            let distance = 2.0 * radius * focal / threshold;
            let eye = centre + Vec3::Z * distance;
            // The image is cropped around the hair, which is centred in it.
            let size = (threshold as usize + 16, threshold as usize + 16);
            let (r0, s0) = lod_topology(16, 8, level - 1);
            let (r1, s1) = lod_topology(16, 8, level);
            let fine = coverage(&strands, r0, s0, eye, focal, size);
            let coarse = coverage(&strands, r1, s1, eye, focal, size);
            // Two pixels either way.
            let grown = morph(&morph(&fine, size, true), size, true);
            let shrunk = morph(&morph(&fine, size, false), size, false);
            let outside = coarse.iter().zip(&grown).filter(|&(c, g)| *c && !g).count();
            let lost = coarse
                .iter()
                .zip(&shrunk)
                .filter(|&(c, s)| !c && *s)
                .count();
            let changed = coarse.iter().zip(&fine).filter(|(c, f)| c != f).count();
            let covered = fine.iter().filter(|&&f| f).count();
            println!(
                "level {} -> {level} at {threshold} px: {changed} of {covered} covered pixels \
                 change, {outside} beyond two pixels outside, {lost} beyond two pixels inside",
                level - 1
            );
            assert!(covered > 100, "the hair is not on the image ({covered} px)");
            // Stated bound: under 3% of the covered pixels change; none appears farther than
            // two pixels outside the finer silhouette; at most one disappears farther than two
            // inside it (a pixel of gap opening between two thinner strands).
            assert!(
                changed * 100 < 3 * covered,
                "{changed} of {covered} pixels change: 3% or more"
            );
            assert!(
                outside == 0 && lost <= 1,
                "the silhouette moved more than two pixels: {outside} out, {lost} in"
            );
        }
    }

    /// The sides for a width, worked by hand from `r (1 - cos(pi / n)) <= 0.5`: at 2 px
    /// (`r = 1`) a triangle is within 0.5 px; at 3 px a square is within 0.44 (a triangle is
    /// 0.75 off); at 8 px 7 sides are within 0.40 (6: 0.54); at 46 px 16 sides (15: 0.503).
    /// Each count is the fewest: one side fewer misses the bound, measured on the polygon.
    #[test]
    fn sides_follow_the_strand_width_on_screen() {
        for (width, sides) in [(0.5, 3), (2.0, 3), (3.0, 4), (8.0, 7), (46.0, 16)] {
            let n = sides_for_width(width, 0.5);
            assert_eq!(n, sides, "{width} px wide");
            // The polygon's outline from every direction: its half-width seen across is the
            // largest projection of its corners; the circle's is r.
            let off = |n: usize| {
                let r = width * 0.5;
                (0..3600)
                    .map(|k| {
                        let view = k as f32 * std::f32::consts::TAU / 3600.0;
                        let reach = (0..n)
                            .map(|i| {
                                let a = i as f32 * std::f32::consts::TAU / n as f32;
                                r * (a - view).cos()
                            })
                            .fold(f32::MIN, f32::max);
                        r - reach
                    })
                    .fold(0.0f32, f32::max)
            };
            assert!(
                off(n) <= 0.5 + 1e-4,
                "{width} px, {n} sides: {} px off",
                off(n)
            );
            if n > 3 {
                assert!(off(n - 1) > 0.5, "{width} px: {} sides would do", n - 1);
            }
        }
        assert_eq!(sides_for_width(1e6, 0.5), tube::MAX_SIDES);
        assert_eq!(sides_for_width(f32::NAN, 0.5), tube::MIN_SIDES);
        let lod = HairLod::default();
        // More sides at once; fewer only as few as 1.25 times the width needs (9 px needs 7,
        // 11.25 px 8; 2 px 3, 2.5 px 4).
        assert_eq!(lod.sides_for(10.5, 7), 8);
        assert_eq!(lod.sides_for(8.0, 8), 7);
        assert_eq!(lod.sides_for(9.0, 8), 8);
        assert_eq!(lod.sides_for(2.0, 4), 4);
        assert_eq!(lod.sides_for(1.6, 4), 3);
        // The first choice, and from no limit, down as from the most sides.
        assert_eq!(lod.sides_for(8.0, 0), 7);
        assert_eq!(lod.sides_for(9.0, 0), 8);
        assert_eq!(lod.sides_for(9.0, u8::MAX), 8);
        assert_eq!(lod.sides_for(8.0, u8::MAX), 7);
        // Wide strands: no limit. Off: no limit.
        assert_eq!(lod.sides_for(1e6, 7), u8::MAX);
        let exact = HairLod {
            silhouette_error: 0.0,
            ..lod
        };
        assert_eq!(exact.sides_for(2.0, 3), 0);
        let off = HairLod {
            enabled: false,
            ..lod
        };
        assert_eq!(off.sides_for(2.0, 3), 0);
    }

    #[test]
    fn levels_follow_the_size_with_hysteresis() {
        let lod = HairLod::default();
        assert_eq!(lod.level_for(500.0, 0), 0);
        assert_eq!(lod.level_for(200.0, 0), 1);
        assert_eq!(lod.level_for(50.0, 0), 2);
        // Back up only past 1.25 x the threshold.
        assert_eq!(lod.level_for(250.0, 1), 1);
        assert_eq!(lod.level_for(301.0, 1), 0);
        assert_eq!(lod.level_for(90.0, 2), 2);
        assert_eq!(lod.level_for(101.0, 2), 1);
        assert_eq!(lod.level_for(400.0, 2), 0);
        assert_eq!(lod.level_for(30.0, 0), 3);
        assert_eq!(lod.level_for(45.0, 3), 3);
        assert_eq!(lod.level_for(51.0, 3), 2);
        let off = HairLod {
            enabled: false,
            ..lod
        };
        assert_eq!(off.level_for(10.0, 2), 0);
        assert_eq!(lod.level_for(f32::NAN, 1), 0);
        assert_eq!(lod_topology(16, 8, 0), (16, 8));
        assert_eq!(lod_topology(16, 8, 1), (12, 8));
        assert_eq!(lod_topology(16, 8, 2), (8, 6));
        assert_eq!(lod_topology(16, 8, 3), (4, 4));
        assert_eq!(lod_topology(4, 3, 2), (3, 3));
    }
}

#[cfg(test)]
pub(crate) mod app_tests {
    use bevy::camera::primitives::Frustum;
    use bevy::camera::{CameraProjection, RenderTargetInfo};
    use bevy::prelude::*;

    use super::*;
    use crate::asset::HairGroom;
    use crate::mesh::{ComputedHairMesh, HairCullingStats, HairMeshPlugin};
    use crate::sim::{Hair, HairSimSettings};

    /// An app with the hair's simulation and meshes, no render app.
    pub(crate) fn lod_app() -> App {
        let mut app = crate::test_support::sim_app(60.0);
        app.add_plugins(HairMeshPlugin).init_asset::<Mesh>();
        app
    }

    /// A 1280x720 camera at the origin looking down -Z (its frustum and projection set by hand:
    /// there is no render app).
    pub(crate) fn camera(world: &mut World) {
        let transform = Transform::IDENTITY;
        let projection = PerspectiveProjection {
            aspect_ratio: 16.0 / 9.0,
            ..default()
        };
        let mut camera = Camera::default();
        camera.computed.clip_from_view = projection.get_clip_from_view();
        camera.computed.target_info = Some(RenderTargetInfo {
            physical_size: UVec2::new(1280, 720),
            scale_factor: 1.0,
        });
        let global = GlobalTransform::from(transform);
        let projection = Projection::Perspective(projection);
        let frustum: Frustum = projection.compute_frustum(&global);
        world.spawn((
            Camera3d::default(),
            camera,
            projection,
            transform,
            global,
            frustum,
        ));
    }

    /// A hair in front of the camera at `z` (negative: in view).
    pub(crate) fn hair(app: &mut App, z: f32) -> (Entity, Entity) {
        let groom = HairGroom::from_strands(
            "head",
            (0..40).map(|i| {
                let a = i as f32 * 0.7;
                let n = Vec3::new(a.cos() * 0.5, 1.0, a.sin() * 0.5).normalize();
                (0..6)
                    .map(|k| n * (0.1 + 0.03 * k as f32))
                    .collect::<Vec<_>>()
            }),
        )
        .unwrap();
        let world = app.world_mut();
        let groom = world.resource_mut::<Assets<HairGroom>>().add(groom);
        let bone = world.spawn(Transform::from_xyz(0.0, 0.0, z)).id();
        let hair = world
            .spawn((
                Hair { groom, ..default() },
                HairSimSettings::default(),
                ChildOf(bone),
            ))
            .id();
        (bone, hair)
    }

    fn mesh_of(app: &App, hair: Entity) -> (u8, usize, usize) {
        let world = app.world();
        let level = world.get::<HairLodLevel>(hair).unwrap().level;
        let computed = world.get::<ComputedHairMesh>(hair).unwrap();
        (level, computed.topology.rings(), computed.topology.sides())
    }

    /// A hair 0.8 m from the camera keeps its 16 x 8 tubes; one 20 m away
    /// drops to level 3 (4 rings) with strands 1.5 px wide, so 3 sides, and is counted; brought
    /// near, it goes back to full.
    #[test]
    fn far_hair_gets_coarser_tubes_and_comes_back() {
        let mut app = lod_app();
        camera(app.world_mut());
        let (_, near) = hair(&mut app, -0.8);
        let (far_bone, far) = hair(&mut app, -20.0);
        for _ in 0..6 {
            app.update();
        }
        let near_px = app.world().get::<HairLodLevel>(near).unwrap().pixels;
        let far_px = app.world().get::<HairLodLevel>(far).unwrap().pixels;
        println!("near hair {near_px:.0} px tall, far hair {far_px:.0} px");
        assert_eq!(mesh_of(&app, near), (0, 16, 8), "near: {near_px} px");
        let strand_px = app.world().get::<HairLodLevel>(far).unwrap().strand_pixels;
        assert!(
            (1.0..2.0).contains(&strand_px),
            "far strands {strand_px} px wide"
        );
        assert_eq!(mesh_of(&app, far), (3, 4, 3), "far: {far_px} px");
        assert_eq!(
            app.world().resource::<HairCullingStats>().reduced,
            [0, 0, 1]
        );
        // Brought to 0.8 m, it is back to full resolution within two frames.
        app.world_mut()
            .get_mut::<Transform>(far_bone)
            .unwrap()
            .translation
            .z = -0.8;
        app.update();
        app.update();
        assert_eq!(mesh_of(&app, far), (0, 16, 8));
        assert_eq!(
            app.world().resource::<HairCullingStats>().reduced,
            [0, 0, 0]
        );
    }

    /// Built on the GPU for the one camera that sees it, a hair whose strands are 1.5 px wide
    /// is drawn as ribbons (two triangles a segment); brought near, it gets half tubes back;
    /// with `ribbon_pixels` 0 it keeps half tubes when far.
    #[test]
    fn thin_strands_on_the_gpu_path_become_ribbons() {
        let mut app = lod_app();
        camera(app.world_mut());
        let (bone, far) = hair(&mut app, -20.0);
        let (_, off) = hair(&mut app, -20.0);
        app.world_mut()
            .entity_mut(far)
            .insert(crate::mesh::HairMeshBuiltOnGpu);
        app.world_mut().entity_mut(off).insert((
            crate::mesh::HairMeshBuiltOnGpu,
            HairLod {
                ribbon_pixels: 0.0,
                ..default()
            },
        ));
        for _ in 0..6 {
            app.update();
        }
        let topology = |app: &App, hair: Entity| {
            let c = app.world().get::<ComputedHairMesh>(hair).unwrap();
            let t = &c.topology;
            (t.is_facing(), t.is_ribbon(), t.triangle_count())
        };
        let level = *app.world().get::<HairLodLevel>(far).unwrap();
        assert!(level.strand_pixels < 2.0 && level.ribbons, "{level:?}");
        // Level 3: 4 rings, so 3 segments of 2 triangles.
        assert_eq!(topology(&app, far), (true, true, 6));
        let (facing, ribbon, _) = topology(&app, off);
        assert!(facing && !ribbon, "ribbons with ribbon_pixels 0");
        app.world_mut()
            .get_mut::<Transform>(bone)
            .unwrap()
            .translation
            .z = -0.8;
        app.update();
        app.update();
        let (facing, ribbon, _) = topology(&app, far);
        assert!(facing && !ribbon, "near: still ribbons");
    }

    /// Ribbons below `ribbon_pixels`, back to tubes only at `hysteresis` times it.
    #[test]
    fn ribbons_switch_with_hysteresis() {
        let lod = HairLod::default();
        assert!(lod.ribbons_for(2.9, false) && !lod.ribbons_for(3.0, false));
        assert!(lod.ribbons_for(3.5, true) && !lod.ribbons_for(3.75, true));
        assert!(!lod.ribbons_for(f32::NAN, true));
        let off = HairLod {
            enabled: false,
            ..default()
        };
        assert!(!off.ribbons_for(1.0, false));
    }
}

#[cfg(test)]
mod culled_rate_tests {
    use super::app_tests::{camera, hair, lod_app};
    use crate::sim::ComputedHair;
    use bevy::prelude::*;

    /// Hair no camera sees simulates at a quarter of the default rate (one
    /// substep a 60 Hz frame), and at the full rate again once it is seen.
    #[test]
    fn culled_hair_simulates_coarser_and_comes_back_at_full_rate() {
        let mut app = lod_app();
        camera(app.world_mut());
        let (_, seen) = hair(&mut app, -0.8);
        // Behind the camera.
        let (behind_bone, behind) = hair(&mut app, 5.0);
        for _ in 0..6 {
            app.update();
        }
        let substeps = |app: &App, e| app.world().get::<ComputedHair>(e).unwrap().stats.substeps;
        assert_eq!((substeps(&app, seen), substeps(&app, behind)), (4, 1));
        app.world_mut()
            .get_mut::<Transform>(behind_bone)
            .unwrap()
            .translation
            .z = -0.8;
        app.update();
        app.update();
        assert_eq!(substeps(&app, behind), 4);
    }

    /// A bone chain hair (not meshed here) is culled by its particles' bounds: behind the
    /// camera it simulates coarser, in front at the full rate.
    #[test]
    fn culled_chain_hair_simulates_coarser_too() {
        use crate::sim::{BoneChainHairs, HairBoneChains, HairSimSettings};
        let mut app = lod_app();
        camera(app.world_mut());
        let chain_at = |app: &mut App, z: f32| {
            let world = app.world_mut();
            let root = world.spawn(Transform::from_xyz(0.0, 0.0, z)).id();
            let mut parent = root;
            for k in 0..3 {
                parent = world
                    .spawn((
                        Name::new(format!("hair_{k}")),
                        Transform::from_xyz(0.0, if k == 0 { 0.0 } else { -0.04 }, 0.0),
                        ChildOf(parent),
                    ))
                    .id();
            }
            let set = world
                .spawn((
                    HairBoneChains::matching(root, |n| n.starts_with("hair_")),
                    HairSimSettings::default(),
                ))
                .id();
            (root, set)
        };
        let (_, seen) = chain_at(&mut app, -0.8);
        let (behind_root, behind) = chain_at(&mut app, 5.0);
        for _ in 0..6 {
            app.update();
        }
        let hair = |app: &App, set| app.world().get::<BoneChainHairs>(set).unwrap().0[0];
        let substeps = |app: &App, set| {
            app.world()
                .get::<ComputedHair>(hair(app, set))
                .unwrap()
                .stats
                .substeps
        };
        assert_eq!((substeps(&app, seen), substeps(&app, behind)), (4, 1));
        app.world_mut()
            .get_mut::<Transform>(behind_root)
            .unwrap()
            .translation
            .z = -0.8;
        app.update();
        app.update();
        assert_eq!(substeps(&app, behind), 4);
    }
}
