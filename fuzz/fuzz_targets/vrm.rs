//! The VRM spring-bone reader on any extension JSON in a glTF with a small node tree: no panic,
//! and everything it accepts points at nodes, colliders and groups that exist, with every
//! number finite and within the documented ranges.
#![no_main]

use bevy::gltf::gltf::Gltf;
use bevy_cartoon_hair::asset::{
    MAX_PARTICLES_PER_STRAND, MAX_VRM_COLLIDERS, MAX_VRM_COORDINATE, MAX_VRM_FORCE, MAX_VRM_GROUPS,
    MAX_VRM_SPRINGS, VrmShape, VrmVersion, parse_vrm_springs,
};
use libfuzzer_sys::fuzz_target;

/// Nodes 0..6: 0 -> (1 -> 2 -> 3, 4 -> 5).
const NODES: usize = 6;

fn unit(v: bevy::math::Vec3) -> bool {
    (v.length() - 1.0).abs() < 1e-3
}

fuzz_target!(|data: &[u8]| {
    let Ok(extensions) = std::str::from_utf8(data) else {
        return;
    };
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"nodes":[{{"children":[1,4]}},{{"children":[2]}},{{"children":[3]}},{{}},{{"children":[5]}},{{}}],"scenes":[{{"nodes":[0]}}],"extensions":{extensions}}}"#
    );
    let Ok(gltf) = Gltf::from_slice(json.as_bytes()) else {
        return;
    };
    let springs = match parse_vrm_springs("f.vrm", &gltf.document) {
        Ok(Some(s)) => s,
        Ok(None) => return,
        Err(e) => {
            assert_eq!(e.file, "f.vrm");
            assert!(e.path.starts_with("extensions.VRM"), "{e}");
            assert!(!e.message.is_empty());
            return;
        }
    };
    assert!(springs.colliders.len() <= MAX_VRM_COLLIDERS);
    assert!(springs.groups.len() <= MAX_VRM_GROUPS);
    assert!(springs.springs.len() <= MAX_VRM_SPRINGS);
    let coord = |v: bevy::math::Vec3| v.is_finite() && v.abs().max_element() <= MAX_VRM_COORDINATE;
    let radius = |r: f32| r.is_finite() && (0.0..=MAX_VRM_COORDINATE).contains(&r);
    for c in &springs.colliders {
        assert!((c.node as usize) < NODES);
        match c.shape {
            VrmShape::Sphere { offset, radius: r, .. } => assert!(coord(offset) && radius(r)),
            VrmShape::Capsule { offset, tail, radius: r, .. } => {
                assert!(coord(offset) && coord(tail) && radius(r));
            }
            VrmShape::Plane { offset, normal } => assert!(coord(offset) && unit(normal)),
        }
    }
    for g in &springs.groups {
        assert!(g.iter().all(|&c| (c as usize) < springs.colliders.len()));
    }
    let mut owner = [None; NODES];
    for (i, s) in springs.springs.iter().enumerate() {
        assert!(s.groups.iter().all(|&g| (g as usize) < springs.groups.len()));
        assert!(s.center.is_none_or(|c| (c as usize) < NODES));
        assert!(s.nodes.iter().all(|&n| (n as usize) < NODES));
        for j in &s.joints {
            assert!(radius(j.hit_radius));
            assert!(j.stiffness.is_finite() && (0.0..=MAX_VRM_FORCE).contains(&j.stiffness));
            assert!(j.gravity_power.is_finite() && (0.0..=MAX_VRM_FORCE).contains(&j.gravity_power));
            assert!((0.0..=1.0).contains(&j.drag_force));
            assert!(unit(j.gravity_dir));
        }
        match springs.version {
            VrmVersion::V1 => {
                assert!(s.nodes.len() <= MAX_PARTICLES_PER_STRAND);
                assert_eq!(s.nodes.len(), s.joints.len());
                // Each joint the child of the one before, and no joint in two springs.
                for n in &s.nodes {
                    assert!(owner[*n as usize].replace(i).is_none(), "node {n} in two springs");
                }
            }
            VrmVersion::V0 => assert_eq!(s.joints.len(), 1),
        }
    }
});
