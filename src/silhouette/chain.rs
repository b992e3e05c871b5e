//! Chaining silhouette edges into ordered polylines ([`SilhouetteChains`]).
//!
//! Unlike the thesis, chaining is linear (per-vertex edge slots kept in a reused
//! [`SilhouetteScratch`] instead of an O(n²) insertion sort), never drops an edge, and splits
//! chains at vertices where more than two silhouette edges meet. Nothing allocates per call once
//! the reused buffers have grown; keep one [`SilhouetteScratch`] and one [`SilhouetteChains`] per
//! thread.
//!
//! A capped tube seen from the side has one closed silhouette loop: the two long sides joined
//! by the visible halves of the root and tip cap rims.

use super::adjacency::{SilhouetteScratch, Slot};

/// One ordered polyline of silhouette vertices, borrowed from [`SilhouetteChains`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SilhouetteChain<'a> {
    /// The vertices in order; each consecutive pair is an input edge. A closed chain lists each
    /// vertex once (the closing edge runs from the last vertex back to the first).
    pub vertices: &'a [u32],
    /// Whether an edge joins the last vertex to the first.
    pub closed: bool,
}

/// Where one chain lies in [`SilhouetteChains::vertices`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChainSpan {
    /// First vertex (index into [`SilhouetteChains::vertices`]).
    pub start: usize,
    /// One past the last vertex.
    pub end: usize,
    /// Whether an edge joins the last vertex to the first.
    pub closed: bool,
}

/// The chains of one strand, stored flat so that rebuilding them does not allocate.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SilhouetteChains {
    /// Every chain's vertices, chain after chain.
    pub vertices: Vec<u32>,
    /// The chains, in the order [`chain_edges`] found them.
    pub spans: Vec<ChainSpan>,
}

impl SilhouetteChains {
    /// Removes every chain, keeping the buffers.
    pub fn clear(&mut self) {
        self.vertices.clear();
        self.spans.clear();
    }

    /// The number of chains.
    pub fn len(&self) -> usize {
        self.spans.len()
    }

    /// Whether there are no chains.
    pub fn is_empty(&self) -> bool {
        self.spans.is_empty()
    }

    /// Chain `i`, if there is one.
    pub fn get(&self, i: usize) -> Option<SilhouetteChain<'_>> {
        self.spans.get(i).map(|s| SilhouetteChain {
            vertices: &self.vertices[s.start..s.end],
            closed: s.closed,
        })
    }

    /// The chains in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = SilhouetteChain<'_>> + '_ {
        self.spans.iter().map(|s| SilhouetteChain {
            vertices: &self.vertices[s.start..s.end],
            closed: s.closed,
        })
    }
}

/// Links `edges` into ordered polylines, written to `out` (cleared first).
///
/// Every input edge ends up in exactly one chain, as a consecutive pair of vertices (or as the
/// closing pair of a closed chain). Chains end at vertices where other than two edges meet
/// (ends of open chains, and junctions of three or more edges, where every branch becomes a
/// chain of its own); loops of vertices with two edges each become closed chains. A chain runs
/// the way its first edge points, so the consistently oriented edges of
/// [`silhouette_edges`](super::adjacency::silhouette_edges)
/// give consistently oriented chains. A self-loop `[v, v]` is a closed chain `[v]`.
///
/// Deterministic. `O(edges)` when vertex ids are small (below `8 * edges.len() + 4096`, as for
/// a strand's mesh: per-vertex lists live in `scratch`, and only the entries a call touches are
/// reset), `O(edges log edges)` otherwise. Does not allocate once `scratch` and `out` have grown.
pub fn chain_edges(
    edges: &[[u32; 2]],
    scratch: &mut SilhouetteScratch,
    out: &mut SilhouetteChains,
) {
    chain_edges_with(edges, scratch, out, true);
}

/// [`chain_edges`], with the fast path for pure loops ([`chain_loops`]) on or off.
pub(super) fn chain_edges_with(
    edges: &[[u32; 2]],
    scratch: &mut SilhouetteScratch,
    out: &mut SilhouetteChains,
    fast_loops: bool,
) {
    out.clear();
    if edges.is_empty() {
        return;
    }
    let SilhouetteScratch {
        ends,
        degree,
        slots,
        used,
        ids,
        next,
        ..
    } = scratch;
    let max_id = edges.iter().map(|e| e[0].max(e[1])).max().unwrap_or(0) as usize;
    let (ends, vertex_count): (&[[u32; 2]], usize) = if max_id < 8 * edges.len() + 4096 {
        (edges, max_id + 1)
    } else {
        ids.clear();
        ids.extend(edges.iter().flatten().copied());
        ids.sort_unstable();
        ids.dedup();
        ends.clear();
        ends.extend(
            edges
                .iter()
                .map(|e| e.map(|v| ids.binary_search(&v).unwrap_or_default() as u32)),
        );
        (ends, ids.len())
    };
    if degree.len() < vertex_count {
        degree.resize(vertex_count, 0);
        slots.resize(vertex_count, [Slot::default(); 2]);
        next.resize(vertex_count, [0; 2]);
    }
    if fast_loops && chain_loops(edges, ends, degree, next, out) {
        return;
    }
    for (e, (pair, ids)) in ends.iter().zip(edges).enumerate() {
        for side in 0..2 {
            let v = pair[side] as usize;
            let d = degree[v];
            if d < 2 {
                slots[v][d as usize] = Slot {
                    edge: e as u32,
                    far: pair[1 - side],
                    far_id: ids[1 - side],
                };
            }
            degree[v] = d + 1;
        }
    }
    used.clear();
    used.resize(edges.len(), false);

    let mut walker = Walker {
        edges,
        ends,
        degree,
        slots,
        used,
        out,
    };
    // Open chains (and loops through junctions) start at vertices of degree other than two.
    for (e, pair) in ends.iter().enumerate() {
        for &v in pair {
            if walker.degree[v as usize] != 2 && !walker.used[e] {
                walker.walk(v, e as u32);
            }
        }
    }
    // What is left are loops of vertices of degree two.
    for (e, pair) in ends.iter().enumerate() {
        if !walker.used[e] {
            walker.walk(pair[0], e as u32);
        }
    }
    // Restore the all-zero invariant of the degrees.
    for pair in ends {
        degree[pair[0] as usize] = 0;
        degree[pair[1] as usize] = 0;
    }
}

/// The common case of [`chain_edges`], fast: when every vertex has exactly one edge leaving it
/// and one arriving (as at every silhouette vertex that is not a junction, since the edges of
/// [`silhouette_edges`] run round the front-facing region), the edges form loops, found by
/// following the edge leaving each vertex. Writes them and returns `true` then; otherwise
/// writes nothing and returns `false`. The chains are those the general walk finds: each loop
/// starts at the first vertex of its first edge. `degree` is all zero before and after.
fn chain_loops(
    edges: &[[u32; 2]],
    ends: &[[u32; 2]],
    degree: &mut [u32],
    next: &mut [[u32; 2]],
    out: &mut SilhouetteChains,
) -> bool {
    // Leaving edges count in the low half of `degree`, arriving ones in the high half.
    const ONE_EACH: u32 = 0x1_0001;
    for (&[a, b], &[_, b_id]) in ends.iter().zip(edges) {
        degree[a as usize] += 1;
        degree[b as usize] += 1 << 16;
        next[a as usize] = [b, b_id];
    }
    let loops = ends
        .iter()
        .all(|&[a, b]| degree[a as usize] == ONE_EACH && degree[b as usize] == ONE_EACH);
    if !loops {
        for &[a, b] in ends {
            degree[a as usize] = 0;
            degree[b as usize] = 0;
        }
        return false;
    }
    // `next` is a permutation of the vertices: following it from any vertex comes back. Visited
    // vertices get their degree reset to zero.
    for (&[start, _], &[start_id, _]) in ends.iter().zip(edges) {
        if degree[start as usize] == 0 {
            continue;
        }
        let begin = out.vertices.len();
        let (mut v, mut id) = (start, start_id);
        loop {
            degree[v as usize] = 0;
            out.vertices.push(id);
            [v, id] = next[v as usize];
            if v == start {
                break;
            }
        }
        out.spans.push(ChainSpan {
            start: begin,
            end: out.vertices.len(),
            closed: true,
        });
    }
    true
}

/// The state of [`chain_edges`] while it walks the chains.
struct Walker<'a> {
    edges: &'a [[u32; 2]],
    ends: &'a [[u32; 2]],
    degree: &'a [u32],
    slots: &'a [[Slot; 2]],
    used: &'a mut [bool],
    out: &'a mut SilhouetteChains,
}

impl Walker<'_> {
    /// Walks a chain from compact vertex `start` along unused edge `first`, through vertices of
    /// degree two, until a vertex of another degree, a dead end or `start` again.
    fn walk(&mut self, start: u32, first: u32) {
        let begin = self.out.vertices.len();
        let [a, b] = self.ends[first as usize];
        let forward = a == start;
        let [a_id, b_id] = self.edges[first as usize];
        let (start_id, mut current, mut current_id) = if forward {
            (a_id, b, b_id)
        } else {
            (b_id, a, a_id)
        };
        self.out.vertices.push(start_id);
        self.used[first as usize] = true;
        let mut edge = first;
        let mut closed = false;
        loop {
            if current == start {
                closed = true;
                break;
            }
            self.out.vertices.push(current_id);
            if self.degree[current as usize] != 2 {
                break;
            }
            let [s0, s1] = self.slots[current as usize];
            let next = if s0.edge == edge { s1 } else { s0 };
            if self.used[next.edge as usize] {
                break;
            }
            self.used[next.edge as usize] = true;
            (edge, current, current_id) = (next.edge, next.far, next.far_id);
        }
        if !forward {
            self.out.vertices[begin..].reverse();
        }
        self.out.spans.push(ChainSpan {
            start: begin,
            end: self.out.vertices.len(),
            closed,
        });
    }
}
