//! Analytic collision shapes the solver tests particles against: spheres, capsules, planes and
//! boxes, in a collider's space ([`LocalShape`]) and posed in the world for one substep
//! ([`Contact`]), with the Coulomb friction applied at a contact.

use bevy::math::{Affine3A, Mat3A, Quat, Vec3, Vec3A};

/// Farthest a collider shape's points may be from its collider's origin, and its largest radius
/// or half extent, in the collider's units (100 km at unit scale).
pub(crate) const MAX_SHAPE_EXTENT: f32 = 1e5;

/// A shape in a collider's space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum LocalShape {
    /// Centre, radius.
    Sphere(Vec3A, f32),
    /// Segment ends, radius.
    Capsule(Vec3A, Vec3A, f32),
    /// A point on the plane, its unit normal (the free side).
    Plane(Vec3A, Vec3A),
    /// Centre, rotation, half extents.
    Box(Vec3A, Quat, Vec3A),
}

/// A shape posed in the world for one substep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ContactShape {
    /// A sphere.
    Sphere {
        /// Centre.
        centre: Vec3A,
        /// Radius.
        radius: f32,
    },
    /// A capsule: every point within `radius` of the segment `a`-`b`.
    Capsule {
        /// One end of the axis.
        a: Vec3A,
        /// The other end.
        b: Vec3A,
        /// Radius.
        radius: f32,
    },
    /// A half space: particles stay on the side `normal` points to.
    Plane {
        /// A point on the plane.
        point: Vec3A,
        /// Unit normal.
        normal: Vec3A,
    },
    /// An oriented box.
    Box {
        /// Centre.
        centre: Vec3A,
        /// Unit axes (columns).
        axes: Mat3A,
        /// Half extents along the axes.
        half: Vec3A,
    },
}

/// One shape at one substep, for the solver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// The shape at the substep's end.
    pub shape: ContactShape,
    /// Keep particles inside (sphere, capsule, box) instead of outside.
    pub inside: bool,
    /// How far the shape moved over the substep (its origin's displacement): friction acts on
    /// the particle's motion relative to it.
    pub shift: Vec3A,
    /// Where a particle can touch the shape: its bounds grown by the largest margin (infinite
    /// for planes and keep-inside shapes). Particles outside skip the test.
    pub reach: (Vec3A, Vec3A),
}

impl Contact {
    /// `shape` at one substep, `inside` or not, moved by `shift`, touched within `margin`.
    pub fn new(shape: ContactShape, inside: bool, shift: Vec3A, margin: f32) -> Self {
        let reach = if inside {
            (Vec3A::NEG_INFINITY, Vec3A::INFINITY)
        } else {
            let (lo, hi) = shape.bounds();
            (lo - margin, hi + margin)
        };
        Self {
            shape,
            inside,
            shift,
            reach,
        }
    }
}

impl LocalShape {
    /// The shape at `pose` (which may scale it: radii by the largest axis scale).
    pub(crate) fn at(&self, pose: &Affine3A) -> ContactShape {
        match *self {
            Self::Sphere(c, r) => ContactShape::Sphere {
                centre: pose.transform_point3a(c),
                radius: r * crate::math::largest_scale(pose),
            },
            Self::Capsule(a, b, r) => ContactShape::Capsule {
                a: pose.transform_point3a(a),
                b: pose.transform_point3a(b),
                radius: r * crate::math::largest_scale(pose),
            },
            Self::Plane(p, n) => ContactShape::Plane {
                point: pose.transform_point3a(p),
                // Normals go by the inverse transpose.
                normal: (pose.matrix3.inverse().transpose() * n).normalize_or(Vec3A::Y),
            },
            Self::Box(c, rotation, half) => {
                let m = pose.matrix3 * Mat3A::from_quat(rotation);
                let lengths = Vec3A::new(m.x_axis.length(), m.y_axis.length(), m.z_axis.length());
                ContactShape::Box {
                    centre: pose.transform_point3a(c),
                    axes: Mat3A::from_cols(
                        m.x_axis.normalize_or(Vec3A::X),
                        m.y_axis.normalize_or(Vec3A::Y),
                        m.z_axis.normalize_or(Vec3A::Z),
                    ),
                    half: half * lengths,
                }
            }
        }
    }

    /// Whether the shape can be collided with: every number finite, points within
    /// [`MAX_SHAPE_EXTENT`] of its collider's origin, radii and half extents greater than 0 and
    /// at most that, a plane's normal not zero. Anything else (a radius of 0 or below, a sphere
    /// 1e19 m away: found by the solver fuzz target) would throw the hair off or overflow.
    pub(crate) fn is_usable(&self) -> bool {
        let point = |p: Vec3A| p.is_finite() && p.abs().max_element() <= MAX_SHAPE_EXTENT;
        let size = |r: f32| r > 0.0 && r <= MAX_SHAPE_EXTENT;
        match *self {
            Self::Sphere(c, r) => point(c) && size(r),
            Self::Capsule(a, b, r) => point(a) && point(b) && size(r),
            Self::Plane(p, n) => point(p) && n.is_finite() && n.length_squared() > 0.5,
            Self::Box(c, q, h) => {
                point(c) && q.is_finite() && size(h.min_element()) && size(h.max_element())
            }
        }
    }

    /// The shape's origin in its collider's space (what friction follows).
    pub(crate) fn origin(&self) -> Vec3A {
        match *self {
            Self::Sphere(c, _) | Self::Plane(c, _) | Self::Box(c, _, _) => c,
            Self::Capsule(a, b, _) => (a + b) * 0.5,
        }
    }
}

impl ContactShape {
    /// World bounds `(min, max)`; a plane's are infinite.
    pub fn bounds(&self) -> (Vec3A, Vec3A) {
        match *self {
            Self::Sphere { centre, radius } => (centre - radius, centre + radius),
            Self::Capsule { a, b, radius } => (a.min(b) - radius, a.max(b) + radius),
            Self::Plane { .. } => (Vec3A::NEG_INFINITY, Vec3A::INFINITY),
            Self::Box { centre, axes, half } => {
                let abs = Mat3A::from_cols(axes.x_axis.abs(), axes.y_axis.abs(), axes.z_axis.abs());
                let e = abs * half;
                (centre - e, centre + e)
            }
        }
    }

    /// Whether the shape, grown by `margin`, can touch the box `(min, max)`.
    pub fn meets(&self, min: Vec3A, max: Vec3A, margin: f32) -> bool {
        if let Self::Plane { point, normal } = *self {
            // The box's corner deepest along -normal decides.
            let corner = Vec3A::select(normal.cmpge(Vec3A::ZERO), min, max);
            return (corner - point).dot(normal) < margin;
        }
        let (lo, hi) = self.bounds();
        (lo - margin).cmple(max).all() && (hi + margin).cmpge(min).all()
    }

    /// Signed distance of `x` from the surface (negative inside) and the outward normal at the
    /// nearest surface point.
    pub fn surface(&self, x: Vec3A) -> (f32, Vec3A) {
        let ball = |c: Vec3A, radius: f32| {
            let d = x - c;
            let len = d.length();
            let n = if len > 1e-9 { d / len } else { Vec3A::Y };
            (len - radius, n)
        };
        match *self {
            Self::Sphere { centre, radius } => ball(centre, radius),
            Self::Capsule { a, b, radius } => {
                let ab = b - a;
                let t = ((x - a).dot(ab) / ab.length_squared().max(1e-20)).clamp(0.0, 1.0);
                ball(a + ab * t, radius)
            }
            Self::Plane { point, normal } => ((x - point).dot(normal), normal),
            Self::Box { centre, axes, half } => {
                let q = axes.transpose() * (x - centre);
                let out = q - q.clamp(-half, half);
                let d = out.length();
                if d > 1e-9 {
                    return (d, axes * (out / d));
                }
                let gap = half - q.abs();
                let axis = if gap.x <= gap.y && gap.x <= gap.z {
                    0
                } else if gap.y <= gap.z {
                    1
                } else {
                    2
                };
                let mut n = Vec3A::ZERO;
                n[axis] = if q[axis] < 0.0 { -1.0 } else { 1.0 };
                (-gap[axis], axes * n)
            }
        }
    }

    /// [`ContactShape::resolve`] for a particle that moved, relative to the shape, from `from` to
    /// `x` this substep: when it came from outside, it stops where it first reached the margin
    /// and keeps only the part of the rest of its motion along the surface. A shape that moves
    /// farther than its own size in a substep can still pass a particle; one that moves less
    /// never does, however fast.
    #[inline]
    pub fn resolve_swept(&self, from: Vec3A, x: Vec3A, margin: f32, inside: bool) -> Option<Vec3A> {
        if inside {
            return self.resolve(x, margin, true);
        }
        let (d, n) = self.surface(x);
        if d >= margin {
            return None;
        }
        if self.surface(from).0 < margin {
            // It was already within the margin: out along the surface's normal.
            return Some(x + n * (margin - d));
        }
        // The first point of the path within the margin, to a hundredth of the path.
        let (mut lo, mut hi) = (0.0f32, 1.0f32);
        for _ in 0..7 {
            let mid = 0.5 * (lo + hi);
            if self.surface(from.lerp(x, mid)).0 >= margin {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let hit = from.lerp(x, lo);
        let n = self.surface(hit).1;
        let rest = x - hit;
        let along = hit + rest - n * rest.dot(n).min(0.0);
        Some(self.resolve(along, margin, false).unwrap_or(along))
    }

    /// Where `x` goes to keep `margin` from the surface (outside, or inside when `inside`), or
    /// `None` when it already does.
    #[inline]
    pub fn resolve(&self, x: Vec3A, margin: f32, inside: bool) -> Option<Vec3A> {
        if inside {
            match *self {
                Self::Box { centre, axes, half } => {
                    // Within every face by the margin.
                    let q = axes.transpose() * (x - centre);
                    let room = (half - margin).max(Vec3A::ZERO);
                    let c = q.clamp(-room, room);
                    return (c != q).then(|| centre + axes * c);
                }
                Self::Sphere { radius, .. } | Self::Capsule { radius, .. } => {
                    // Within `radius - margin` of the centre (or the axis).
                    let (d, n) = self.surface(x);
                    let (from_axis, room) = (d + radius, (radius - margin).max(0.0));
                    return (from_axis > room).then(|| x - n * (from_axis - room));
                }
                // A plane keeps the side its normal points to either way.
                Self::Plane { .. } => {}
            }
        }
        let (d, n) = self.surface(x);
        (d < margin).then(|| x + n * (margin - d))
    }
}

/// Coulomb friction at a contact that moved a particle from `x` to `to`: its motion this
/// substep (`to - p`, less the surface's own `shift`) loses up to `friction` times the push along
/// the surface, all of it when that is more than the motion (static friction).
#[inline]
pub(crate) fn rub(x: Vec3, to: Vec3, p: Vec3, shift: Vec3, friction: f32) -> Vec3 {
    let push = to - x;
    let depth = push.length();
    if depth <= 1e-12 {
        return to;
    }
    let n = push / depth;
    let rel = to - p - shift;
    let tangent = rel - n * rel.dot(n);
    let slide = tangent.length();
    if slide <= 1e-12 {
        return to;
    }
    to - tangent * (friction * depth / slide).min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_push_out_and_keep_in() {
        let m = 0.01;
        let capsule = ContactShape::Capsule {
            a: Vec3A::ZERO,
            b: Vec3A::X,
            radius: 0.1,
        };
        let to = capsule
            .resolve(Vec3A::new(0.5, 0.05, 0.0), m, false)
            .unwrap();
        assert!((to - Vec3A::new(0.5, 0.11, 0.0)).length() < 1e-6, "{to}");
        assert!(
            capsule
                .resolve(Vec3A::new(0.5, 0.2, 0.0), m, false)
                .is_none()
        );
        // Inside mode keeps the point within radius - margin of the axis.
        let to = capsule.resolve(Vec3A::new(0.5, 0.2, 0.0), m, true).unwrap();
        assert!((to - Vec3A::new(0.5, 0.09, 0.0)).length() < 1e-6, "{to}");

        let plane = LocalShape::Plane(Vec3A::ZERO, Vec3A::Y).at(&Affine3A::from_rotation_z(0.3));
        let to = plane.resolve(Vec3A::new(1.0, -1.0, 0.0), m, false).unwrap();
        let ContactShape::Plane { normal, .. } = plane else {
            unreachable!()
        };
        assert!((to.dot(normal) - m).abs() < 1e-5);

        let cube = LocalShape::Box(Vec3A::ZERO, Quat::from_rotation_y(0.5), Vec3A::splat(0.2))
            .at(&Affine3A::from_translation(Vec3::new(0.0, 1.0, 0.0)));
        // A point just inside the top face leaves through it.
        let to = cube.resolve(Vec3A::new(0.0, 1.19, 0.0), m, false).unwrap();
        assert!((to - Vec3A::new(0.0, 1.21, 0.0)).length() < 1e-5, "{to}");
        assert!(cube.meets(Vec3A::new(-1.0, 1.2, -1.0), Vec3A::splat(5.0), m));
        assert!(!cube.meets(Vec3A::splat(2.0), Vec3A::splat(3.0), m));
        assert!(plane.meets(Vec3A::splat(-1.0), Vec3A::splat(1.0), m));
        assert!(!plane.meets(Vec3A::new(0.0, 5.0, 0.0), Vec3A::new(1.0, 6.0, 1.0), m));
    }

    #[test]
    fn friction_holds_a_small_slide_and_slows_a_large_one() {
        // A particle pushed 1 mm up onto a floor, having moved along it.
        let on_floor = |slide: f32, shift: f32| {
            let x = Vec3::new(slide, -0.001, 0.0);
            rub(
                x,
                Vec3::new(slide, 0.0, 0.0),
                Vec3::ZERO,
                Vec3::X * shift,
                1.0,
            )
        };
        // A slide smaller than friction x depth stops.
        let held = on_floor(0.0005, 0.0);
        assert!(held.x.abs() < 1e-7, "{held}");
        // A larger one loses friction x depth of its length.
        let slowed = on_floor(0.01, 0.0);
        assert!((slowed.x - 0.009).abs() < 1e-6, "{slowed}");
        // Riding a surface that moves with it: nothing to rub.
        let carried = on_floor(0.01, 0.01);
        assert!((carried.x - 0.01).abs() < 1e-7, "{carried}");
    }
}
