//! Lock ids for a character's own hair mesh: each separate piece of the mesh (a lock modelled as
//! its own shell) gets one of the three lock ids the hair's prepass writes beside its normals,
//! so the image-space outline's lines between locks ([`LockLines`](super::LockLines)) separate
//! modelled locks as they separate the crate's strands.
//!
//! The prepass reads a lock's id from the whole part of its second UVs' `u` (as the crate's strand
//! meshes carry it); the fraction keeps the first UVs' `u`, so hatching reads the same `u`.

use bevy::mesh::{Indices, VertexAttributeValues};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;

/// The most pieces whose ids are chosen from their neighbours (the choice compares every pair);
/// past it, pieces take ids in turn.
const MAX_COLOURED_PIECES: usize = 4096;

/// Gives each separate piece of `mesh` a lock id (0, 1 or 2) in its second UVs
/// (`ATTRIBUTE_UV_1`, replaced): `u` is the id plus the fraction of the first UVs' `u` (0.5
/// without first UVs), `v` the first UVs' `v` (0 without). Vertices joined by a triangle or at
/// the same position (split for a seam or a hard edge) are one piece. Pieces whose bounds
/// overlap take different ids where three allow, the largest first, so locks lying on each
/// other are told apart. Returns the number of pieces. Errors when the mesh has no `Float32x3`
/// positions on the CPU or an index past its vertices.
pub fn lock_ids_by_piece(mesh: &mut Mesh) -> Result<usize, String> {
    let Some(VertexAttributeValues::Float32x3(positions)) =
        mesh.attribute(Mesh::ATTRIBUTE_POSITION)
    else {
        return Err("it has no positions on the CPU (Float32x3)".into());
    };
    let n = positions.len();
    let mut pieces = Pieces::new(n);
    let triangles: Vec<usize> = match mesh.indices() {
        Some(indices @ (Indices::U16(_) | Indices::U32(_))) => indices.iter().collect(),
        None => (0..n).collect(),
    };
    if let Some(bad) = triangles.iter().find(|&&i| i >= n) {
        return Err(format!("its index {bad} is past its {n} vertices"));
    }
    for t in triangles.chunks_exact(3) {
        pieces.join(t[0], t[1]);
        pieces.join(t[0], t[2]);
    }
    let mut first_at: HashMap<[u32; 3], usize> = HashMap::default();
    for (i, p) in positions.iter().enumerate() {
        let first = *first_at.entry(p.map(f32::to_bits)).or_insert(i);
        pieces.join(i, first);
    }
    // Each vertex's piece, numbered by first vertex, and each piece's finite bounds.
    let mut number: HashMap<usize, usize> = HashMap::default();
    let mut bounds: Vec<(Vec3, Vec3)> = Vec::new();
    let piece_of: Vec<usize> = (0..n)
        .map(|i| {
            let root = pieces.root(i);
            let k = *number.entry(root).or_insert_with(|| {
                bounds.push((Vec3::INFINITY, Vec3::NEG_INFINITY));
                bounds.len() - 1
            });
            let p = Vec3::from_array(positions[i]);
            if p.is_finite() {
                bounds[k] = (bounds[k].0.min(p), bounds[k].1.max(p));
            }
            k
        })
        .collect();
    let ids = choose_ids(&bounds);
    let first_uvs = match mesh.attribute(Mesh::ATTRIBUTE_UV_0) {
        Some(VertexAttributeValues::Float32x2(uvs)) if uvs.len() == n => Some(uvs.clone()),
        _ => None,
    };
    let second_uvs: Vec<[f32; 2]> = (0..n)
        .map(|i| {
            let id = f32::from(ids[piece_of[i]]);
            match &first_uvs {
                // At most 0.999 past the id, so the sum never rounds up to the next id.
                Some(uvs) => {
                    let [u, v] = uvs[i].map(|x| if x.is_finite() { x } else { 0.0 });
                    [id + u.rem_euclid(1.0).min(0.999), v]
                }
                None => [id + 0.5, 0.0],
            }
        })
        .collect();
    mesh.insert_attribute(Mesh::ATTRIBUTE_UV_1, second_uvs);
    Ok(bounds.len())
}

/// Whether `mesh` brings second UVs of its own whose `u` reaches 1 or more: the hair's prepass
/// reads the whole part as a lock id, so the outline's lines between locks would fall along the
/// edges of its UV tiles.
pub(crate) fn second_uvs_read_as_locks(mesh: &Mesh) -> bool {
    match mesh.attribute(Mesh::ATTRIBUTE_UV_1) {
        Some(VertexAttributeValues::Float32x2(uvs)) => uvs.iter().any(|[u, _]| *u >= 1.0),
        _ => false,
    }
}

/// Ids for pieces with these bounds: largest first, each the id fewest of the pieces already
/// given one whose bounds overlap its own (grown by 1% of the whole's size) have; in turn past
/// [`MAX_COLOURED_PIECES`].
fn choose_ids(bounds: &[(Vec3, Vec3)]) -> Vec<u8> {
    if bounds.len() > MAX_COLOURED_PIECES {
        return (0..bounds.len()).map(|k| (k % 3) as u8).collect();
    }
    let (lo, hi) = bounds
        .iter()
        .filter(|(lo, hi)| lo.cmple(*hi).all())
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), (lo, hi)| {
            (a.min(*lo), b.max(*hi))
        });
    let margin = if lo.cmple(hi).all() {
        0.01 * (hi - lo).length()
    } else {
        0.0
    };
    let size = |k: usize| {
        let (lo, hi) = bounds[k];
        if lo.cmple(hi).all() {
            (hi - lo).length()
        } else {
            0.0
        }
    };
    let mut order: Vec<usize> = (0..bounds.len()).collect();
    order.sort_by(|&a, &b| size(b).total_cmp(&size(a)).then(a.cmp(&b)));
    let overlap = |a: usize, b: usize| {
        let ((alo, ahi), (blo, bhi)) = (bounds[a], bounds[b]);
        (alo - margin).cmple(bhi).all() && (blo - margin).cmple(ahi).all()
    };
    let mut ids: Vec<Option<u8>> = vec![None; bounds.len()];
    for &k in &order {
        let mut used = [0usize; 3];
        for (j, id) in ids.iter().enumerate() {
            if let Some(id) = id
                && overlap(k, j)
            {
                used[usize::from(*id)] += 1;
            }
        }
        let fewest = (0..3u8)
            .min_by_key(|&id| used[usize::from(id)])
            .unwrap_or(0);
        ids[k] = Some(fewest);
    }
    ids.into_iter().map(|id| id.unwrap_or(0)).collect()
}

/// Union-find over a mesh's vertices.
struct Pieces(Vec<usize>);

impl Pieces {
    fn new(n: usize) -> Self {
        Self((0..n).collect())
    }

    fn root(&mut self, mut i: usize) -> usize {
        while self.0[i] != i {
            self.0[i] = self.0[self.0[i]];
            i = self.0[i];
        }
        i
    }

    fn join(&mut self, a: usize, b: usize) {
        let (a, b) = (self.root(a), self.root(b));
        if a != b {
            self.0[a.max(b)] = a.min(b);
        }
    }
}

#[cfg(test)]
mod tests {
    use bevy::asset::RenderAssetUsages;
    use bevy::mesh::PrimitiveTopology;

    use super::*;

    fn mesh(positions: Vec<[f32; 3]>, indices: Option<Vec<u32>>) -> Mesh {
        let mut m = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        );
        m.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
        if let Some(i) = indices {
            m.insert_indices(Indices::U32(i));
        }
        m
    }

    fn second_uvs(m: &Mesh) -> Vec<[f32; 2]> {
        match m.attribute(Mesh::ATTRIBUTE_UV_1) {
            Some(VertexAttributeValues::Float32x2(uvs)) => uvs.clone(),
            other => panic!("no second UVs: {other:?}"),
        }
    }

    fn id(uv: [f32; 2]) -> u32 {
        uv[0].floor() as u32
    }

    /// A 2 x 2 square as two triangles whose shared edge's vertices are split (one piece), a
    /// small triangle lying on the square (overlapping it: another id), a second one on both (the
    /// third id) and a triangle far off (the first id again: no neighbours).
    #[test]
    fn each_piece_gets_an_id_and_overlapping_pieces_differ() {
        let mut positions = vec![
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 2.0, 0.0],
            // The second triangle's copies of the shared edge (a seam).
            [0.0, 0.0, 0.0],
            [2.0, 2.0, 0.0],
            [0.0, 2.0, 0.0],
        ];
        positions.extend([[0.5, 0.5, 0.1], [1.0, 0.5, 0.1], [0.5, 1.0, 0.1]]);
        positions.extend([[0.6, 0.6, 0.1], [1.1, 0.6, 0.1], [0.6, 1.1, 0.1]]);
        positions.extend([[9.0, 9.0, 0.0], [9.5, 9.0, 0.0], [9.0, 9.5, 0.0]]);
        let indices: Vec<u32> = (0..15).collect();
        let mut indexed = mesh(positions.clone(), Some(indices));
        assert_eq!(lock_ids_by_piece(&mut indexed), Ok(4));
        let ids: Vec<u32> = second_uvs(&indexed).into_iter().map(id).collect();
        assert_eq!(ids, [0, 0, 0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 0, 0, 0]);
        // Without indices the vertices are the triangles in order: the same pieces.
        let mut plain = mesh(positions, None);
        assert_eq!(lock_ids_by_piece(&mut plain), Ok(4));
        assert_eq!(second_uvs(&plain), second_uvs(&indexed));
        // Without first UVs, each vertex is at the middle of its id.
        assert!(second_uvs(&plain).iter().all(|uv| uv[0].fract() == 0.5));
    }

    /// The second UVs carry the first UVs' `u` fraction (never rounding up to the next id) and
    /// `v`; a non-finite one reads as 0.
    #[test]
    fn the_second_uvs_keep_the_first_uvs_u_and_v() {
        let mut m = mesh(vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], None);
        m.insert_attribute(
            Mesh::ATTRIBUTE_UV_0,
            vec![[0.25, 0.75], [1.9999999, 0.5], [f32::NAN, 0.125]],
        );
        assert_eq!(lock_ids_by_piece(&mut m), Ok(1));
        let uvs = second_uvs(&m);
        assert_eq!(uvs[0], [0.25, 0.75]);
        assert_eq!(uvs[1], [0.999, 0.5]);
        assert_eq!(uvs[2], [0.0, 0.125]);
    }

    /// Second UVs of a mesh's own are lock ids to the prepass only where their `u` reaches 1.
    #[test]
    fn own_second_uvs_past_one_are_found() {
        let mut m = mesh(vec![[0.0; 3]; 3], None);
        assert!(!second_uvs_read_as_locks(&m), "no second UVs");
        m.insert_attribute(
            Mesh::ATTRIBUTE_UV_1,
            vec![[0.0, 0.0], [0.999, 1.0], [-3.0, 2.0]],
        );
        assert!(!second_uvs_read_as_locks(&m), "within one tile");
        m.insert_attribute(
            Mesh::ATTRIBUTE_UV_1,
            vec![[0.0, 0.0], [1.0, 0.0], [0.5, 0.5]],
        );
        assert!(second_uvs_read_as_locks(&m), "a second tile");
    }

    /// A mesh without positions on the CPU, or with an index past its vertices, is an error
    /// saying so; a NaN position still makes a piece of its own triangle.
    #[test]
    fn broken_meshes_are_refused_and_nan_positions_tolerated() {
        let mut empty = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        );
        assert!(
            lock_ids_by_piece(&mut empty)
                .unwrap_err()
                .contains("positions")
        );
        let mut past = mesh(vec![[0.0; 3]; 3], Some(vec![0, 1, 7]));
        let err = lock_ids_by_piece(&mut past).unwrap_err();
        assert!(
            err.contains("index 7") && err.contains("3 vertices"),
            "{err}"
        );
        let mut nan = mesh(
            vec![
                [f32::NAN; 3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [5.0; 3],
                [6.0, 5.0, 5.0],
                [5.0, 6.0, 5.0],
            ],
            None,
        );
        assert_eq!(lock_ids_by_piece(&mut nan), Ok(2));
        assert!(second_uvs(&nan).iter().all(|uv| uv[0].is_finite()));
    }
}
