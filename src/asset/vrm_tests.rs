//! The VRM spring-bone reader: what a file says, and every rule it enforces on hostile JSON.

use bevy::gltf::gltf;
use bevy::prelude::*;

use super::vrm::*;

/// A glTF document: node 0 (the head) with children 1 -> 2 -> 3 (a hair chain) and 4 -> 5,
/// and the given root extensions.
fn document(extensions: &str) -> gltf::Document {
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},
        "nodes":[{{"name":"head","children":[1,4]}},{{"name":"h1","children":[2]}},
                 {{"name":"h2","children":[3]}},{{"name":"h3"}},
                 {{"name":"s1","children":[5]}},{{"name":"s2"}}],
        "scenes":[{{"nodes":[0]}}],
        "extensions":{extensions}}}"#
    );
    gltf::Gltf::from_slice(json.as_bytes())
        .expect("test document")
        .document
}

const V1: &str = r#"{"VRMC_springBone":{"specVersion":"1.0",
  "colliders":[
    {"node":0,"shape":{"sphere":{"offset":[0,0.1,0],"radius":0.09}}},
    {"node":0,"shape":{"capsule":{"offset":[0,0,0],"tail":[0,-0.2,0],"radius":0.04}}},
    {"node":0,"shape":{"sphere":{"offset":[0,-10000,0],"radius":0}},
     "extensions":{"VRMC_springBone_extended_collider":{"specVersion":"1.0",
       "shape":{"sphere":{"offset":[0,0.1,0],"radius":0.3,"inside":true}}}}},
    {"node":0,"shape":{"sphere":{"offset":[0,-1000,0],"radius":1000}},
     "extensions":{"VRMC_springBone_extended_collider":{"specVersion":"1.0-draft",
       "shape":{"plane":{"offset":[0,-0.3,0],"normal":[0,2,0]}}}}}],
  "colliderGroups":[{"name":"head","colliders":[0,1]},{"name":"bubble","colliders":[2,3]}],
  "springs":[
    {"name":"bangs","joints":[
       {"node":1,"hitRadius":0.02,"stiffness":2,"gravityPower":0.1,"gravityDir":[0,-1,0],"dragForce":0.4},
       {"node":2,"stiffness":1},{"node":3}],
     "colliderGroups":[0],"center":0},
    {"joints":[{"node":4},{"node":5}],"colliderGroups":[1]}]}}"#;

#[test]
fn a_vrm_1_file_reads_its_colliders_groups_springs_and_defaults() {
    let s = parse_vrm_springs("a.vrm", &document(V1)).unwrap().unwrap();
    assert_eq!(s.version, VrmVersion::V1);
    assert_eq!(s.colliders.len(), 4);
    assert_eq!(
        s.colliders[0].shape,
        VrmShape::Sphere {
            offset: Vec3::new(0.0, 0.1, 0.0),
            radius: 0.09,
            inside: false
        }
    );
    assert!(matches!(s.colliders[1].shape, VrmShape::Capsule { tail, .. } if tail.y == -0.2));
    // The extended shape replaces its fallback.
    assert_eq!(
        s.colliders[2].shape,
        VrmShape::Sphere {
            offset: Vec3::new(0.0, 0.1, 0.0),
            radius: 0.3,
            inside: true
        }
    );
    // A plane's normal is made unit length.
    assert_eq!(
        s.colliders[3].shape,
        VrmShape::Plane {
            offset: Vec3::new(0.0, -0.3, 0.0),
            normal: Vec3::Y
        }
    );
    assert_eq!(s.groups, vec![vec![0, 1], vec![2, 3]]);
    let bangs = &s.springs[0];
    assert_eq!(bangs.name, "bangs");
    assert_eq!(bangs.nodes, vec![1, 2, 3]);
    assert_eq!(bangs.groups, vec![0]);
    assert_eq!(bangs.center, Some(0));
    assert_eq!(bangs.joints[0].stiffness, 2.0);
    assert_eq!(bangs.joints[0].drag_force, 0.4);
    assert_eq!(bangs.joints[0].hit_radius, 0.02);
    // The specification's defaults where the file is silent.
    assert_eq!(bangs.joints[2].stiffness, 1.0);
    assert_eq!(bangs.joints[2].drag_force, 0.5);
    assert_eq!(bangs.joints[2].gravity_power, 0.0);
    assert_eq!(bangs.joints[2].gravity_dir, Vec3::NEG_Y);
    assert_eq!(s.springs[1].center, None);
}

const V0: &str = r#"{"VRM":{"secondaryAnimation":{
  "colliderGroups":[{"node":0,"colliders":[{"offset":{"x":0.01,"y":0.1,"z":0.02},"radius":0.09}]}],
  "boneGroups":[{"comment":"hair","stiffiness":0.8,"gravityPower":0.2,
    "gravityDir":{"x":0,"y":-1,"z":0},"dragForce":0.3,"center":-1,"hitRadius":0.01,
    "bones":[1,4],"colliderGroups":[0]}]}}}"#;

#[test]
fn a_vrm_0_file_converts_collider_offsets_from_unity_space() {
    let s = parse_vrm_springs("old.vrm", &document(V0))
        .unwrap()
        .unwrap();
    assert_eq!(s.version, VrmVersion::V0);
    // z is opposite in VRM 0.x (written in Unity's left-handed space).
    assert_eq!(
        s.colliders[0].shape,
        VrmShape::Sphere {
            offset: Vec3::new(0.01, 0.1, -0.02),
            radius: 0.09,
            inside: false
        }
    );
    assert_eq!(s.colliders[0].node, 0);
    let g = &s.springs[0];
    assert_eq!(
        (g.name.as_str(), g.nodes.clone(), g.center),
        ("hair", vec![1, 4], None)
    );
    assert_eq!(g.joints.len(), 1);
    assert_eq!(g.joints[0].stiffness, 0.8);
    assert_eq!(g.joints[0].drag_force, 0.3);
    assert_eq!(g.joints[0].gravity_dir, Vec3::NEG_Y);
}

#[test]
fn a_gltf_without_spring_bones_has_none() {
    assert_eq!(
        parse_vrm_springs("plain.glb", &document("{}")).unwrap(),
        None
    );
    // VRM 0.x metadata without secondaryAnimation.
    let meta = r#"{"VRM":{"meta":{"title":"x"}}}"#;
    assert_eq!(
        parse_vrm_springs("meta.vrm", &document(meta)).unwrap(),
        None
    );
}

/// `V1` with `from` replaced by `to` must fail at `path` with a message containing `says`.
fn refused(from: &str, to: &str, path: &str, says: &str) {
    assert!(V1.contains(from), "{from} not in the test file");
    let json = V1.replacen(from, to, 1);
    let err =
        parse_vrm_springs("bad.vrm", &document(&json)).expect_err(&format!("{to} was accepted"));
    assert_eq!(err.file, "bad.vrm");
    assert_eq!(err.path, path, "{err}");
    assert!(err.message.contains(says), "{err}");
    assert!(
        err.to_string()
            .starts_with("bad.vrm: extensions.VRMC_springBone"),
        "{err}"
    );
}

#[test]
fn hostile_vrm_1_json_is_refused_naming_the_json_path() {
    let c = "extensions.VRMC_springBone.colliders";
    let s = "extensions.VRMC_springBone.springs";
    refused(
        r#"{"node":3}]"#,
        r#"{"node":99}]"#,
        &format!("{s}[0].joints[2].node"),
        "node 99 does not exist (the file has 6 nodes)",
    );
    refused(
        r#"{"node":2,"stiffness":1}"#,
        r#"{"node":4,"stiffness":1}"#,
        &format!("{s}[0].joints[1].node"),
        "not a child of the previous joint",
    );
    refused(
        r#"{"node":4},{"node":5}"#,
        r#"{"node":2},{"node":3}"#,
        &format!("{s}[1].joints[0].node"),
        "also a joint of spring 0",
    );
    refused(
        r#""stiffness":2"#,
        r#""stiffness":-1"#,
        &format!("{s}[0].joints[0].stiffness"),
        "outside [0, 10000]",
    );
    refused(
        r#""dragForce":0.4"#,
        r#""dragForce":1.5"#,
        &format!("{s}[0].joints[0].dragForce"),
        "outside [0, 1]",
    );
    refused(
        r#""gravityPower":0.1"#,
        r#""gravityPower":1e39"#,
        &format!("{s}[0].joints[0].gravityPower"),
        "outside",
    );
    refused(
        r#""gravityDir":[0,-1,0]"#,
        r#""gravityDir":[0,0,0]"#,
        &format!("{s}[0].joints[0].gravityDir"),
        "zero length",
    );
    refused(
        r#""gravityDir":[0,-1,0]"#,
        r#""gravityDir":[0,-1]"#,
        &format!("{s}[0].joints[0].gravityDir"),
        "expected 3 numbers",
    );
    refused(
        r#""hitRadius":0.02"#,
        r#""hitRadius":"big""#,
        &format!("{s}[0].joints[0].hitRadius"),
        "expected a number, found a string",
    );
    refused(
        r#""radius":0.09"#,
        r#""radius":-0.09"#,
        &format!("{c}[0].shape.sphere.radius"),
        "outside",
    );
    refused(
        r#""offset":[0,0.1,0],"radius":0.09"#,
        r#""offset":[0,1e6,0],"radius":0.09"#,
        &format!("{c}[0].shape.sphere.offset"),
        "within ±100000",
    );
    refused(
        r#"{"sphere":{"offset":[0,0.1,0],"radius":0.09}}"#,
        r#"{"sphere":{},"capsule":{}}"#,
        &format!("{c}[0].shape"),
        "exactly one of",
    );
    refused(
        r#"{"node":0,"shape":{"sphere":{"offset":[0,0.1,0],"radius":0.09}}}"#,
        r#"{"node":0}"#,
        &format!("{c}[0]"),
        "without a shape",
    );
    refused(
        r#""specVersion":"1.0-draft""#,
        r#""specVersion":"2.0""#,
        &format!("{c}[3].extensions.VRMC_springBone_extended_collider.specVersion"),
        "not a version",
    );
    refused(
        r#""normal":[0,2,0]"#,
        r#""normal":[0,0,0]"#,
        &format!("{c}[3].extensions.VRMC_springBone_extended_collider.shape.plane.normal"),
        "zero length",
    );
    refused(
        r#""colliders":[0,1]"#,
        r#""colliders":[0,7]"#,
        "extensions.VRMC_springBone.colliderGroups[0].colliders[1]",
        "collider 7 does not exist",
    );
    refused(
        r#""colliderGroups":[1]"#,
        r#""colliderGroups":[2]"#,
        &format!("{s}[1].colliderGroups[0]"),
        "collider group 2 does not exist",
    );
    refused(
        r#""center":0"#,
        r#""center":-3"#,
        &format!("{s}[0].center"),
        "expected a node index",
    );
    refused(
        r#""name":"bangs""#,
        &format!(r#""name":"{}""#, "x".repeat(MAX_VRM_NAME + 1)),
        &format!("{s}[0].name"),
        "longer than",
    );
    refused(
        r#""springs":["#,
        r#""springs":{"a":1},"x":["#,
        s,
        "expected an array",
    );
}

#[test]
fn oversized_lists_are_refused_before_they_are_read() {
    // More springs than allowed: refused on the count, not after reading each.
    let many = vec![r#"{"joints":[]}"#; MAX_VRM_SPRINGS + 1].join(",");
    let json = format!(r#"{{"VRMC_springBone":{{"springs":[{many}]}}}}"#);
    let err = parse_vrm_springs("many.vrm", &document(&json)).unwrap_err();
    assert_eq!(err.path, "extensions.VRMC_springBone.springs");
    assert!(err.message.contains("more than the 4096 allowed"), "{err}");
    // A chain longer than a strand may be.
    let joints = vec![r#"{"node":0}"#; crate::asset::MAX_PARTICLES_PER_STRAND + 1].join(",");
    let json = format!(r#"{{"VRMC_springBone":{{"springs":[{{"joints":[{joints}]}}]}}}}"#);
    let err = parse_vrm_springs("long.vrm", &document(&json)).unwrap_err();
    assert_eq!(err.path, "extensions.VRMC_springBone.springs[0].joints");
    // VRM 0.x: a collider group's node must exist, and so must a bone.
    let bad = V0.replace(r#""bones":[1,4]"#, r#""bones":[1,40]"#);
    let err = parse_vrm_springs("old.vrm", &document(&bad)).unwrap_err();
    assert_eq!(
        err.path,
        "extensions.VRM.secondaryAnimation.boneGroups[0].bones[1]"
    );
    let bad = V0.replace(r#""dragForce":0.3"#, r#""dragForce":-0.3"#);
    let err = parse_vrm_springs("old.vrm", &document(&bad)).unwrap_err();
    assert_eq!(
        err.path,
        "extensions.VRM.secondaryAnimation.boneGroups[0].dragForce"
    );
}

/// `V1` with `limit` as the `VRMC_springBone_limit` extension of spring 0's second joint.
fn with_limit(limit: &str) -> Result<VrmSprings, VrmError> {
    let json = V1.replacen(
        r#"{"node":2,"stiffness":1}"#,
        &format!(r#"{{"node":2,"stiffness":1,"extensions":{{"VRMC_springBone_limit":{limit}}}}}"#),
        1,
    );
    parse_vrm_springs("l.vrm", &document(&json)).map(|s| s.expect("springs"))
}

#[test]
fn joint_angle_limits_are_read_clamped_and_checked() {
    let s = with_limit(
        r#"{"specVersion":"1.0-draft","limit":{"cone":{"angle":0.5,"rotation":[0,0,2,0]}}}"#,
    )
    .unwrap();
    let limit = s.springs[0].joints[1].limit.expect("a limit");
    assert_eq!(limit.shape, JointLimitShape::Cone { angle: 0.5 });
    // The quaternion is normalised.
    assert!(
        limit
            .rotation
            .abs_diff_eq(Quat::from_xyzw(0.0, 0.0, 1.0, 0.0), 1e-6)
    );
    assert_eq!(s.springs[0].joints[0].limit, None);
    // Angles past what a shape allows are read as the largest (the draft's rule).
    let s = with_limit(r#"{"specVersion":"1.0-draft","limit":{"spherical":{"pitch":4,"yaw":3}}}"#)
        .unwrap();
    assert_eq!(
        s.springs[0].joints[1].limit.map(|l| l.shape),
        Some(JointLimitShape::Spherical {
            pitch: std::f32::consts::PI,
            yaw: std::f32::consts::FRAC_PI_2
        })
    );
    let p = "extensions.VRMC_springBone.springs[0].joints[1].extensions.VRMC_springBone_limit";
    for (limit, path, says) in [
        (
            r#"{"limit":{"cone":{"angle":1}}}"#.to_string(),
            p.to_string(),
            "no specVersion",
        ),
        (
            r#"{"specVersion":"2.0","limit":{"cone":{"angle":1}}}"#.into(),
            format!("{p}.specVersion"),
            "not a version",
        ),
        (
            r#"{"specVersion":"1.0-draft","limit":{"cone":{"angle":1},"hinge":{"angle":1}}}"#
                .into(),
            format!("{p}.limit"),
            "exactly one of",
        ),
        (
            r#"{"specVersion":"1.0-draft","limit":{"hinge":{}}}"#.into(),
            format!("{p}.limit.hinge"),
            "no `angle`",
        ),
        (
            r#"{"specVersion":"1.0-draft","limit":{"cone":{"angle":-0.1}}}"#.into(),
            format!("{p}.limit.cone.angle"),
            "outside",
        ),
        (
            r#"{"specVersion":"1.0-draft","limit":{"cone":{"angle":1,"rotation":[0,0,0,0]}}}"#
                .into(),
            format!("{p}.limit.cone.rotation"),
            "zero length",
        ),
        (
            r#"{"specVersion":"1.0-draft","limit":{"cone":{"angle":1,"rotation":[0,0,1]}}}"#.into(),
            format!("{p}.limit.cone.rotation"),
            "4 finite numbers",
        ),
    ] {
        let err = with_limit(&limit).expect_err(&limit);
        assert_eq!(err.path, path, "{err}");
        assert!(err.message.contains(says), "{err}");
    }
}
