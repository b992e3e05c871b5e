//! Bone chains in the solver ([`StepInput::particles_only`]): the pass down the chains that
//! moves their particles alone, and the structural nodes placed from them once a frame.

use bevy::math::{Affine3A, Vec3A};

use super::solver::{Batch, LANES, PINNED, StepInput, predict, solve_distance};

impl Batch {
    /// The solver's pass down the chains for bone chains ([`StepInput::particles_only`]): one
    /// pass down the particles alone. Each is predicted, then its springs to the particles
    /// before it are solved (Gauss-Seidel), then the anchor spring of the particle two back,
    /// which no later spring touches this substep.
    #[inline(always)]
    pub(super) fn integrate_particles<const N: usize>(
        batches: &mut [&mut Batch; N],
        input: &StepInput,
        anchors: &[f32],
        bone: &Affine3A,
    ) {
        let g = input.gravity_h2.to_array();
        let d = input.damping;
        let [edge, bend, _] = input.alpha;
        let n = batches[0].nodes.len();
        for k in (PINNED..n).step_by(2) {
            let mut xk = [[[0.0; LANES]; 3]; N];
            for b in 0..N {
                xk[b] = predict(&mut batches[b].nodes[k], g, d);
            }
            if k == PINNED {
                // The first free particle hangs on the pinned nodes: on the root particle by its
                // edge, and by bending springs on the structural point beside its segment and the
                // ghost behind the root, which hold its segment at its styled angle to the bone
                // (loose bending leaves it free to swing every way, as a VRM joint of no
                // stiffness).
                for (s, alpha) in [(0, bend), (1, edge), (2, bend)] {
                    if alpha.is_infinite() {
                        continue;
                    }
                    for b in 0..N {
                        let (head, tail) = batches[b].nodes.split_at_mut(k);
                        solve_distance(
                            &mut head[k - s - 1].x,
                            &mut xk[b],
                            &tail[0].rest[s],
                            0.0,
                            alpha,
                        );
                    }
                }
            } else {
                if edge.is_finite() {
                    for b in 0..N {
                        let (head, tail) = batches[b].nodes.split_at_mut(k);
                        solve_distance(&mut head[k - 2].x, &mut xk[b], &tail[0].rest[1], 1.0, edge);
                    }
                }
                if bend.is_finite() {
                    let wj = if k - 4 < PINNED { 0.0 } else { 1.0 };
                    for b in 0..N {
                        let Batch {
                            nodes, bend: rest, ..
                        } = &mut *batches[b];
                        solve_distance(&mut nodes[k - 4].x, &mut xk[b], &rest[k], wj, bend);
                    }
                }
            }
            for b in 0..N {
                batches[b].nodes[k].x = xk[b];
                // Particle k-4 is touched by no later spring this substep.
                if k >= PINNED + 4 {
                    batches[b].solve_anchor(k - 4, anchors, bone);
                }
            }
        }
        for batch in batches.iter_mut() {
            for k in (PINNED..n).step_by(2).filter(|&k| k + 4 >= n) {
                batch.solve_anchor(k, anchors, bone);
            }
        }
    }

    /// Puts each free structural node ([`StepInput::particles_only`]) at its styled offset from
    /// the middle of its segment, turned with `bone`, at rest.
    pub(super) fn place_structure(&mut self, bone: &Affine3A) {
        let n = self.nodes.len();
        for k in (PINNED + 1..n.saturating_sub(1)).step_by(2) {
            let (before, after) = (self.nodes[k - 1].x, self.nodes[k + 1].x);
            let (lb, lk, la) = (&self.local[k - 1], &self.local[k], &self.local[k + 1]);
            let node = &mut self.nodes[k];
            for l in 0..LANES {
                let styled = Vec3A::new(
                    lk[0][l] - 0.5 * (lb[0][l] + la[0][l]),
                    lk[1][l] - 0.5 * (lb[1][l] + la[1][l]),
                    lk[2][l] - 0.5 * (lb[2][l] + la[2][l]),
                );
                let offset = bone.matrix3 * styled;
                for c in 0..3 {
                    let x = 0.5 * (before[c][l] + after[c][l]) + offset[c];
                    node.x[c][l] = x;
                    node.p[c][l] = x;
                }
            }
        }
    }
}
