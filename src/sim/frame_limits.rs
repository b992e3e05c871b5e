//! The solver's limits once a frame, after the last substep: the style limit (no particle
//! farther than a distance from its anchor) and the strain limit (no chain edge longer than a
//! multiple of its rest length). Both move a node's previous position with it: no velocity made.

// Loops run over lanes by index (`for l in 0..LANES`) with several arrays indexed at once: the
// compiler vectorises across strands.
#![expect(
    clippy::needless_range_loop,
    reason = "lane loops index several arrays at once, which the compiler vectorises"
)]

use bevy::math::Affine3A;

use super::solver::{Batch, LANES, Lane, Node, PINNED, dot, transform};

impl Batch {
    /// Pulls every free node that lies farther than `max` from its anchor (at the bone pose
    /// `bone`) back onto that sphere; its previous position moves with it, so no velocity is
    /// made. VRM's angle limits and Magica Cloth's backstop do the same job: bangs never enter the
    /// face however hard the head shakes.
    #[inline(always)]
    pub(super) fn limit_to_style(&mut self, max: f32, bone: &Affine3A, particles_only: bool) {
        for node in self.free_nodes_mut(particles_only) {
            let a = transform(bone, &node.anchor);
            for l in 0..LANES {
                let d = [
                    node.x[0][l] - a[0][l],
                    node.x[1][l] - a[1][l],
                    node.x[2][l] - a[2][l],
                ];
                let len = dot(d, d).sqrt().max(1e-12);
                let f = (1.0 - max / len).max(0.0);
                for c in 0..3 {
                    node.x[c][l] -= f * d[c];
                    node.p[c][l] -= f * d[c];
                }
            }
        }
    }

    /// Follow the leader (Müller et al. 2012), root to tip: each free node that lies farther than
    /// `max` times the rest length from the node before it (and, for particles, from the particle
    /// before) is pulled in along that line; its previous position moves with it, so no velocity
    /// is made. The rest length is the longer of the styled one and the anchors' (a keyframe may
    /// stretch the style). Returns `false` when no node was near its limit, none moved.
    /// With `particles_only`, only the particles' own segments.
    #[inline(always)]
    pub(super) fn limit_stretch(&mut self, max: f32, particles_only: bool) -> bool {
        let Self { nodes, local, .. } = self;
        let n = nodes.len();
        let mut pulled = false;
        for k in PINNED..n {
            if particles_only && k % 2 == 0 {
                continue;
            }
            let (head, tail) = nodes.split_at_mut(k);
            let nk = &mut tail[0];
            // The chain edge, then (particles, odd k) the strand's own segment. Pinned nodes
            // sit on the base pose, not on their anchors.
            let anchor_of = |j: usize| {
                if j < PINNED {
                    &local[j]
                } else {
                    &head[j].anchor
                }
            };
            if !particles_only {
                pulled |= pull_within(nk, &head[k - 1].x, anchor_of(k - 1), 0, max);
            }
            if k % 2 == 1 {
                pulled |= pull_within(nk, &head[k - 2].x, anchor_of(k - 2), 1, max);
            }
        }
        pulled
    }
}

/// How far under the square of a stretch limit a squared length must be for
/// [`pull_within`] to know, without rounding in doubt, that the limit pulls nothing.
const CLEARLY_WITHIN: f32 = 1.0 - 1e-4;

/// Pulls `node` toward `xj` (lane by lane) where it lies farther than `max` times its rest
/// distance `rest[s]` (or the anchors' distance `anchor - aj`, if longer); its previous position
/// moves with it. Returns `false` when every lane was clearly within, none moved.
#[inline(always)]
fn pull_within(node: &mut Node, xj: &[Lane; 3], aj: &[Lane; 3], s: usize, max: f32) -> bool {
    // A row whose every lane is clearly within the styled rest length, which the anchors'
    // distance can only lengthen, would be pulled by nothing: found by squared lengths alone
    // (no square roots or divisions), the usual case, since the springs hold lengths within a
    // few percent. A lane near the limit, or not finite, takes the full test below.
    let mut beyond = 0u32;
    for l in 0..LANES {
        let (dx, dy, dz) = (
            node.x[0][l] - xj[0][l],
            node.x[1][l] - xj[1][l],
            node.x[2][l] - xj[2][l],
        );
        let limit = max * node.rest[s][l];
        let within = dx * dx + dy * dy + dz * dz <= limit * limit * CLEARLY_WITHIN;
        beyond |= u32::from(!within);
    }
    if beyond == 0 {
        return false;
    }
    let mut f = [0.0; LANES];
    let mut d = [[0.0; LANES]; 3];
    for l in 0..LANES {
        for c in 0..3 {
            d[c][l] = node.x[c][l] - xj[c][l];
        }
        let (ax, ay, az) = (
            node.anchor[0][l] - aj[0][l],
            node.anchor[1][l] - aj[1][l],
            node.anchor[2][l] - aj[2][l],
        );
        let rest = node.rest[s][l].max((ax * ax + ay * ay + az * az).sqrt());
        let len = (d[0][l] * d[0][l] + d[1][l] * d[1][l] + d[2][l] * d[2][l])
            .sqrt()
            .max(1e-12);
        // The share of d beyond the limit; 0 when within it.
        f[l] = (1.0 - max * rest / len).max(0.0);
    }
    for c in 0..3 {
        for l in 0..LANES {
            node.x[c][l] -= f[l] * d[c][l];
            node.p[c][l] -= f[l] * d[c][l];
        }
    }
    true
}
