//! VRM spring bones: the `VRMC_springBone` 1.0 extension (with
//! `VRMC_springBone_extended_collider`) and VRM 0.x `secondaryAnimation`, read from a glTF
//! document and checked.
//!
//! The JSON is hostile input like the crate's own files: every count is bounded before anything
//! is stored, every number is checked against the range the specification gives, every node
//! index against the document, and an error names the file, the JSON path of the value
//! (`extensions.VRMC_springBone.springs[3].joints[2].node`) and what to do. Positions are JSON
//! paths rather than line and column because Bevy's glTF loader has parsed the JSON (a `.vrm` is
//! binary glTF) before this reads it.
//!
//! Nothing here simulates: [`VrmSprings`] is what the file says, in glTF's coordinates (a VRM
//! 0.x collider offset is converted from the Unity space it was written in: `z` negated, as
//! UniVRM and three-vrm do). The simulation side (`sim::vrm`) turns it into bone chains and
//! colliders.

use std::f32::consts::{FRAC_PI_2, PI};

use bevy::gltf::gltf;

use bevy::prelude::*;
use serde_json::Value;

/// Most springs (VRM 1.0) or bone groups (VRM 0.x) a file may have.
pub const MAX_VRM_SPRINGS: usize = 4096;
/// Most colliders a file may have (VRM 0.x: over all collider groups).
pub const MAX_VRM_COLLIDERS: usize = 4096;
/// Most collider groups a file may have, and most entries in any one list of indices.
pub const MAX_VRM_GROUPS: usize = 4096;
/// Most joints over all springs (VRM 1.0) or root bones over all groups (VRM 0.x).
pub const MAX_VRM_JOINTS: usize = 65_536;
/// Longest spring or collider group name, in bytes.
pub const MAX_VRM_NAME: usize = 1024;
/// Largest coordinate, radius or distance (in the node's units).
pub const MAX_VRM_COORDINATE: f32 = 1e5;
/// Largest `stiffness` and `gravityPower`.
pub const MAX_VRM_FORCE: f32 = 1e4;

/// Which VRM extension the springs came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum VrmVersion {
    /// `VRMC_springBone` 1.0: each spring lists its joints; the last joint is only a tail.
    #[default]
    V1,
    /// VRM 0.x `secondaryAnimation`: each bone group names root bones whose every descendant
    /// swings, with a tail 7 cm past each leaf.
    V0,
}

/// A collider's shape, in its node's space (offsets and radii in the node's units).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum VrmShape {
    /// A sphere; `inside`: joints are kept inside it (extended collider).
    Sphere {
        /// Centre.
        offset: Vec3,
        /// Radius.
        radius: f32,
        /// Keep joints inside.
        inside: bool,
    },
    /// A capsule from `offset` to `tail`.
    Capsule {
        /// One end's centre.
        offset: Vec3,
        /// The other end's centre.
        tail: Vec3,
        /// Radius.
        radius: f32,
        /// Keep joints inside.
        inside: bool,
    },
    /// A plane (extended collider): joints stay on the side `normal` points to.
    Plane {
        /// A point on the plane.
        offset: Vec3,
        /// Its normal, unit length.
        normal: Vec3,
    },
}

/// One collider: a shape on a node.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct VrmCollider {
    /// glTF node index.
    pub node: u32,
    /// The shape.
    pub shape: VrmShape,
}

/// The shape of a [`JointLimit`], in the limit's own frame, where the joint's bone points along
/// `+Y` at rest (`VRMC_springBone_limit` 1.0 draft). Angles in radians.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum JointLimitShape {
    /// The bone stays within `angle` of `+Y` (`[0, pi]`).
    Cone {
        /// Half the cone's opening.
        angle: f32,
    },
    /// The bone turns only about `X`, within `angle` of `+Y` (`[0, pi]`).
    Hinge {
        /// The largest turn either way.
        angle: f32,
    },
    /// The bone's pitch (about `X`, toward `+Z`) stays within `pitch` (`[0, pi]`) and its yaw
    /// (toward `+X`) within `yaw` (`[0, pi/2]`).
    Spherical {
        /// The largest pitch either way.
        pitch: f32,
        /// The largest yaw either way.
        yaw: f32,
    },
}

/// An angle limit on a joint: the direction from the joint to its child stays inside
/// [`JointLimit::shape`], whose frame is the joint's bind rotation under its posed parent, turned
/// so `+Y` runs along the bone, then by [`JointLimit::rotation`].
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct JointLimit {
    /// The allowed directions.
    pub shape: JointLimitShape,
    /// The shape's turn from its default orientation (unit length).
    pub rotation: Quat,
}

/// A joint's parameters, as the file gives them (defaults where it is silent).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct VrmJoint {
    /// Radius of the joint's hit sphere (node units). Default `0`.
    pub hit_radius: f32,
    /// Pull back to the bind direction, `>= 0`. Default `1`.
    pub stiffness: f32,
    /// Strength of gravity, `>= 0`. Default `0`.
    pub gravity_power: f32,
    /// Gravity's direction, unit length. Default `-Y`.
    pub gravity_dir: Vec3,
    /// Share of the velocity lost per update, `[0, 1]`. Default `0.5` (VRM 1.0) or `0.4`
    /// (VRM 0.x, as UniVRM).
    pub drag_force: f32,
    /// Its angle limit (`VRMC_springBone_limit` on a VRM 1.0 joint), if any.
    pub limit: Option<JointLimit>,
}

impl VrmJoint {
    fn defaults(version: VrmVersion) -> Self {
        Self {
            hit_radius: 0.0,
            stiffness: 1.0,
            gravity_power: 0.0,
            gravity_dir: Vec3::NEG_Y,
            drag_force: match version {
                VrmVersion::V1 => 0.5,
                VrmVersion::V0 => 0.4,
            },
            limit: None,
        }
    }
}

/// A spring (VRM 1.0) or bone group (VRM 0.x).
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct VrmSpring {
    /// Its name (VRM 0.x: `comment`), maybe empty.
    pub name: String,
    /// VRM 1.0: the joint nodes, root first; each is the parent of the next, and the last is
    /// only a tail. VRM 0.x: the root bones, each swinging with all its descendants.
    pub nodes: Vec<u32>,
    /// VRM 1.0: each joint's parameters (the last joint's are unused). VRM 0.x: one entry for
    /// the whole group.
    pub joints: Vec<VrmJoint>,
    /// Indices into [`VrmSprings::groups`]: the only colliders this spring collides with.
    pub groups: Vec<u32>,
    /// The node whose motion the spring's inertia is measured against, if any.
    pub center: Option<u32>,
}

/// Everything a VRM file says about its spring bones, checked.
#[derive(Clone, Debug, Default, PartialEq, Reflect)]
pub struct VrmSprings {
    /// Which extension it came from.
    pub version: VrmVersion,
    /// Every collider.
    pub colliders: Vec<VrmCollider>,
    /// Collider groups: indices into [`VrmSprings::colliders`].
    pub groups: Vec<Vec<u32>>,
    /// Springs.
    pub springs: Vec<VrmSpring>,
}

/// What is wrong with a VRM file's spring bones.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{file}: {path}: {message}")]
pub struct VrmError {
    /// The file (asset path).
    pub file: String,
    /// JSON path of the offending value.
    pub path: String,
    /// What is wrong and what to do.
    pub message: String,
}

/// Reads the spring bones of a glTF document: `VRMC_springBone` if present, else VRM 0.x
/// `secondaryAnimation`; `Ok(None)` when it has neither.
pub fn parse_vrm_springs(
    file: &str,
    document: &gltf::Document,
) -> Result<Option<VrmSprings>, VrmError> {
    let nodes = Nodes::of(document);
    let reader = Reader {
        file,
        nodes: &nodes,
    };
    if let Some(v1) = document.extension_value("VRMC_springBone") {
        return reader.v1(v1, "extensions.VRMC_springBone").map(Some);
    }
    let v0 = document
        .extension_value("VRM")
        .and_then(|vrm| vrm.get("secondaryAnimation"));
    match v0 {
        Some(v0) => reader.v0(v0, "extensions.VRM.secondaryAnimation").map(Some),
        None => Ok(None),
    }
}

/// The node tree: each node's parent.
struct Nodes {
    parent: Vec<Option<u32>>,
}

impl Nodes {
    fn of(document: &gltf::Document) -> Self {
        let mut parent = vec![None; document.nodes().len()];
        for node in document.nodes() {
            for child in node.children() {
                if let Some(p) = parent.get_mut(child.index()) {
                    *p = u32::try_from(node.index()).ok();
                }
            }
        }
        Self { parent }
    }

    fn len(&self) -> usize {
        self.parent.len()
    }
}

struct Reader<'a> {
    file: &'a str,
    nodes: &'a Nodes,
}

type Res<T> = Result<T, VrmError>;

impl Reader<'_> {
    fn err<T>(&self, path: &str, message: impl Into<String>) -> Res<T> {
        Err(VrmError {
            file: self.file.to_owned(),
            path: path.to_owned(),
            message: message.into(),
        })
    }

    fn object<'v>(&self, v: &'v Value, path: &str) -> Res<&'v serde_map::Map> {
        match v.as_object() {
            Some(o) => Ok(o),
            None => self.err(path, format!("expected an object, found {}", kind(v))),
        }
    }

    /// An optional array, at most `max` long.
    fn array<'v>(
        &self,
        o: &'v serde_map::Map,
        key: &str,
        path: &str,
        max: usize,
    ) -> Res<&'v [Value]> {
        let Some(v) = o.get(key) else {
            return Ok(&[]);
        };
        let path = format!("{path}.{key}");
        match v.as_array() {
            Some(a) if a.len() <= max => Ok(a),
            Some(a) => self.err(
                &path,
                format!(
                    "{} entries, more than the {max} allowed; split the model",
                    a.len()
                ),
            ),
            None => self.err(&path, format!("expected an array, found {}", kind(v))),
        }
    }

    fn number(
        &self,
        o: &serde_map::Map,
        key: &str,
        path: &str,
        range: (f32, f32),
        default: f32,
    ) -> Res<f32> {
        let Some(v) = o.get(key) else {
            return Ok(default);
        };
        let path = format!("{path}.{key}");
        let Some(x) = v.as_f64() else {
            return self.err(&path, format!("expected a number, found {}", kind(v)));
        };
        let x = x as f32;
        if !x.is_finite() || x < range.0 || x > range.1 {
            return self.err(
                &path,
                format!(
                    "{x} is outside [{}, {}]; fix the value in the VRM exporter",
                    range.0, range.1
                ),
            );
        }
        Ok(x)
    }

    fn boolean(&self, o: &serde_map::Map, key: &str, path: &str) -> Res<bool> {
        match o.get(key) {
            None => Ok(false),
            Some(Value::Bool(b)) => Ok(*b),
            Some(v) => self.err(
                &format!("{path}.{key}"),
                format!("expected true or false, found {}", kind(v)),
            ),
        }
    }

    /// A node index, checked against the document.
    fn node(&self, v: &Value, path: &str) -> Res<u32> {
        match v.as_u64() {
            Some(i) if (i as usize) < self.nodes.len() => Ok(i as u32),
            Some(i) => self.err(
                path,
                format!(
                    "node {i} does not exist (the file has {} nodes)",
                    self.nodes.len()
                ),
            ),
            None => self.err(path, format!("expected a node index, found {}", kind(v))),
        }
    }

    /// The required node index at `o.node`; `what` names the object in the error.
    fn node_at(&self, o: &serde_map::Map, path: &str, what: &str) -> Res<u32> {
        match o.get("node") {
            Some(node) => self.node(node, &format!("{path}.node")),
            None => self.err(path, format!("{what} without a node")),
        }
    }

    /// An index into a list of `len`, named `what`.
    fn index(&self, v: &Value, path: &str, len: usize, what: &str) -> Res<u32> {
        match v.as_u64() {
            Some(i) if (i as usize) < len => Ok(i as u32),
            Some(i) => self.err(
                path,
                format!("{what} {i} does not exist (the file has {len})"),
            ),
            None => self.err(path, format!("expected an index, found {}", kind(v))),
        }
    }

    fn name(&self, o: &serde_map::Map, key: &str, path: &str) -> Res<String> {
        match o.get(key) {
            None => Ok(String::new()),
            Some(Value::String(s)) if s.len() <= MAX_VRM_NAME => Ok(s.clone()),
            Some(Value::String(s)) => self.err(
                &format!("{path}.{key}"),
                format!("{} bytes, longer than the {MAX_VRM_NAME} allowed", s.len()),
            ),
            Some(v) => self.err(
                &format!("{path}.{key}"),
                format!("expected a string, found {}", kind(v)),
            ),
        }
    }

    /// A vector given as `[x, y, z]` (VRM 1.0) or `{"x":, "y":, "z":}` (VRM 0.x).
    fn vec3(
        &self,
        o: &serde_map::Map,
        key: &str,
        path: &str,
        default: Vec3,
        max: f32,
    ) -> Res<Vec3> {
        let Some(v) = o.get(key) else {
            return Ok(default);
        };
        let path = format!("{path}.{key}");
        let parts: [Option<&Value>; 3] = match v {
            Value::Array(a) if a.len() == 3 => [a.first(), a.get(1), a.get(2)],
            Value::Object(m) => [m.get("x"), m.get("y"), m.get("z")],
            _ => return self.err(&path, format!("expected 3 numbers, found {}", kind(v))),
        };
        let mut out = [0.0f32; 3];
        for (slot, part) in out.iter_mut().zip(parts) {
            // A missing VRM 0.x component is 0, as in UniVRM.
            let x = match part {
                None => 0.0,
                Some(p) => match p.as_f64() {
                    Some(x) => x as f32,
                    None => {
                        return self.err(&path, format!("expected a number, found {}", kind(p)));
                    }
                },
            };
            if !x.is_finite() || x.abs() > max {
                return self.err(&path, format!("{x} is not a finite number within ±{max}"));
            }
            *slot = x;
        }
        Ok(Vec3::from(out))
    }

    fn direction(&self, o: &serde_map::Map, key: &str, path: &str, default: Vec3) -> Res<Vec3> {
        let v = self.vec3(o, key, path, default, MAX_VRM_COORDINATE)?;
        match v.try_normalize() {
            Some(n) => Ok(n),
            None => self.err(
                &format!("{path}.{key}"),
                "a direction of zero length; give a unit vector",
            ),
        }
    }

    fn v1(&self, v: &Value, path: &str) -> Res<VrmSprings> {
        let root = self.object(v, path)?;
        let mut colliders = Vec::new();
        for (i, c) in self
            .array(root, "colliders", path, MAX_VRM_COLLIDERS)?
            .iter()
            .enumerate()
        {
            let p = format!("{path}.colliders[{i}]");
            let c = self.object(c, &p)?;
            let node = self.node_at(c, &p, "a collider")?;
            let extended = c
                .get("extensions")
                .and_then(|e| e.get("VRMC_springBone_extended_collider"));
            let shape = match extended {
                Some(ext) => {
                    let ep = format!("{p}.extensions.VRMC_springBone_extended_collider");
                    let ext = self.object(ext, &ep)?;
                    match ext.get("specVersion").and_then(Value::as_str) {
                        Some("1.0" | "1.0-draft") => {}
                        other => {
                            return self.err(
                                &format!("{ep}.specVersion"),
                                format!(
                                    "{other:?} is not a version this reads (\"1.0\", \"1.0-draft\")"
                                ),
                            );
                        }
                    }
                    self.shape(ext, &ep, true)?
                }
                None => self.shape(c, &p, false)?,
            };
            colliders.push(VrmCollider { node, shape });
        }
        let mut groups = Vec::new();
        for (i, g) in self
            .array(root, "colliderGroups", path, MAX_VRM_GROUPS)?
            .iter()
            .enumerate()
        {
            let p = format!("{path}.colliderGroups[{i}]");
            let g = self.object(g, &p)?;
            self.name(g, "name", &p)?;
            let mut members = Vec::new();
            for (k, c) in self
                .array(g, "colliders", &p, MAX_VRM_GROUPS)?
                .iter()
                .enumerate()
            {
                members.push(self.index(
                    c,
                    &format!("{p}.colliders[{k}]"),
                    colliders.len(),
                    "collider",
                )?);
            }
            groups.push(members);
        }
        let mut springs = Vec::new();
        let mut owner: Vec<Option<usize>> = vec![None; self.nodes.len()];
        let mut total = 0usize;
        for (i, s) in self
            .array(root, "springs", path, MAX_VRM_SPRINGS)?
            .iter()
            .enumerate()
        {
            let p = format!("{path}.springs[{i}]");
            let s = self.object(s, &p)?;
            let name = self.name(s, "name", &p)?;
            let list = self.array(s, "joints", &p, crate::asset::MAX_PARTICLES_PER_STRAND)?;
            total += list.len();
            if total > MAX_VRM_JOINTS {
                return self.err(
                    &format!("{p}.joints"),
                    format!("more than {MAX_VRM_JOINTS} joints in all"),
                );
            }
            let mut nodes = Vec::with_capacity(list.len());
            let mut joints = Vec::with_capacity(list.len());
            for (k, j) in list.iter().enumerate() {
                let jp = format!("{p}.joints[{k}]");
                let j = self.object(j, &jp)?;
                let node = self.node_at(j, &jp, "a joint")?;
                if let Some(&prev) = nodes.last()
                    && self.nodes.parent[node as usize] != Some(prev)
                {
                    return self.err(
                        &format!("{jp}.node"),
                        format!(
                            "node {node} is not a child of the previous joint, node {prev}; list \
                             every node between them as a joint (skipped nodes are not supported)"
                        ),
                    );
                }
                if let Some(other) = owner[node as usize].replace(i) {
                    return self.err(
                        &format!("{jp}.node"),
                        format!("node {node} is also a joint of spring {other}; a joint belongs to one spring"),
                    );
                }
                nodes.push(node);
                joints.push(self.joint(j, &jp, VrmVersion::V1)?);
            }
            let groups_of = self.group_refs(s, &p, groups.len())?;
            let center = match s.get("center") {
                None => None,
                Some(c) => Some(self.node(c, &format!("{p}.center"))?),
            };
            springs.push(VrmSpring {
                name,
                nodes,
                joints,
                groups: groups_of,
                center,
            });
        }
        Ok(VrmSprings {
            version: VrmVersion::V1,
            colliders,
            groups,
            springs,
        })
    }

    fn group_refs(&self, s: &serde_map::Map, p: &str, len: usize) -> Res<Vec<u32>> {
        let mut out = Vec::new();
        for (k, g) in self
            .array(s, "colliderGroups", p, MAX_VRM_GROUPS)?
            .iter()
            .enumerate()
        {
            out.push(self.index(
                g,
                &format!("{p}.colliderGroups[{k}]"),
                len,
                "collider group",
            )?);
        }
        Ok(out)
    }

    fn joint(&self, j: &serde_map::Map, p: &str, version: VrmVersion) -> Res<VrmJoint> {
        let d = VrmJoint::defaults(version);
        let stiffness_key = match version {
            VrmVersion::V1 => "stiffness",
            // VRM 0.x spells it so.
            VrmVersion::V0 => "stiffiness",
        };
        Ok(VrmJoint {
            hit_radius: self.number(j, "hitRadius", p, (0.0, MAX_VRM_COORDINATE), d.hit_radius)?,
            stiffness: self.number(j, stiffness_key, p, (0.0, MAX_VRM_FORCE), d.stiffness)?,
            gravity_power: self.number(
                j,
                "gravityPower",
                p,
                (0.0, MAX_VRM_FORCE),
                d.gravity_power,
            )?,
            gravity_dir: self.direction(j, "gravityDir", p, d.gravity_dir)?,
            drag_force: self.number(j, "dragForce", p, (0.0, 1.0), d.drag_force)?,
            limit: match version {
                VrmVersion::V1 => self.limit(j, p)?,
                VrmVersion::V0 => None,
            },
        })
    }

    /// A joint's `extensions.VRMC_springBone_limit`, if present: `specVersion` "1.0-draft" (or
    /// "1.0"), `limit` with exactly one of `cone`, `hinge`, `spherical`, angles in radians (`>= 0`;
    /// larger than the shape allows are read as the largest, as the draft says), `rotation` a
    /// non-zero quaternion `[x, y, z, w]`.
    fn limit(&self, j: &serde_map::Map, p: &str) -> Res<Option<JointLimit>> {
        let Some(ext) = j
            .get("extensions")
            .and_then(|e| e.get("VRMC_springBone_limit"))
        else {
            return Ok(None);
        };
        let p = format!("{p}.extensions.VRMC_springBone_limit");
        let ext = self.object(ext, &p)?;
        match ext.get("specVersion") {
            Some(Value::String(v)) if v == "1.0-draft" || v == "1.0" => {}
            Some(v) => {
                return self.err(
                    &format!("{p}.specVersion"),
                    format!("{v} is not a version this crate reads (\"1.0-draft\")"),
                );
            }
            None => return self.err(&p, "no specVersion (\"1.0-draft\")"),
        }
        let Some(limit) = ext.get("limit") else {
            return self.err(&p, "no `limit`");
        };
        let p = format!("{p}.limit");
        let limit = self.object(limit, &p)?;
        let (which, o, sp) = self.one_of(limit, &["cone", "hinge", "spherical"], &p)?;
        let angle = |key: &str, most: f32| -> Res<f32> {
            if !o.contains_key(key) {
                return self.err(&sp, format!("no `{key}` (radians)"));
            }
            Ok(self.number(o, key, &sp, (0.0, f32::MAX), 0.0)?.min(most))
        };
        let shape = match which {
            "cone" => JointLimitShape::Cone {
                angle: angle("angle", PI)?,
            },
            "hinge" => JointLimitShape::Hinge {
                angle: angle("angle", PI)?,
            },
            _ => JointLimitShape::Spherical {
                pitch: angle("pitch", PI)?,
                yaw: angle("yaw", FRAC_PI_2)?,
            },
        };
        let rotation = match o.get("rotation") {
            None => Quat::IDENTITY,
            Some(v) => {
                let rp = format!("{sp}.rotation");
                let parts: Option<Vec<f32>> = v.as_array().filter(|a| a.len() == 4).map(|a| {
                    a.iter()
                        .filter_map(|x| x.as_f64().map(|x| x as f32))
                        .collect()
                });
                match parts {
                    Some(q) if q.len() == 4 && q.iter().all(|x| x.is_finite()) => {
                        let q = Quat::from_xyzw(q[0], q[1], q[2], q[3]);
                        if q.length_squared() < 1e-12 {
                            return self
                                .err(&rp, "a rotation of zero length; give a unit quaternion");
                        }
                        q.normalize()
                    }
                    _ => {
                        return self.err(
                            &rp,
                            format!("expected 4 finite numbers [x, y, z, w], found {}", kind(v)),
                        );
                    }
                }
            }
        };
        Ok(Some(JointLimit { shape, rotation }))
    }

    /// The one key of `kinds` that `o` has (an error unless exactly one), its object and path.
    fn one_of<'v>(
        &self,
        o: &'v serde_map::Map,
        kinds: &[&'static str],
        p: &str,
    ) -> Res<(&'static str, &'v serde_map::Map, String)> {
        let present: Vec<&'static str> = kinds
            .iter()
            .copied()
            .filter(|k| o.contains_key(*k))
            .collect();
        let [which] = present[..] else {
            return self.err(
                p,
                format!("needs exactly one of {kinds:?}, has {present:?}"),
            );
        };
        let sp = format!("{p}.{which}");
        Ok((which, self.object(&o[which], &sp)?, sp))
    }

    /// A `shape` object: exactly one of sphere, capsule (and, extended, plane).
    fn shape(&self, o: &serde_map::Map, p: &str, extended: bool) -> Res<VrmShape> {
        let Some(shape) = o.get("shape") else {
            return self.err(p, "a collider without a shape");
        };
        let p = format!("{p}.shape");
        let shape = self.object(shape, &p)?;
        let kinds: &[&str] = if extended {
            &["sphere", "capsule", "plane"]
        } else {
            &["sphere", "capsule"]
        };
        let (which, s, sp) = self.one_of(shape, kinds, &p)?;
        let radius = || self.number(s, "radius", &sp, (0.0, MAX_VRM_COORDINATE), 0.0);
        let offset = self.vec3(s, "offset", &sp, Vec3::ZERO, MAX_VRM_COORDINATE)?;
        let inside = extended && self.boolean(s, "inside", &sp)?;
        Ok(match which {
            "sphere" => VrmShape::Sphere {
                offset,
                radius: radius()?,
                inside,
            },
            "capsule" => VrmShape::Capsule {
                offset,
                tail: self.vec3(s, "tail", &sp, Vec3::ZERO, MAX_VRM_COORDINATE)?,
                radius: radius()?,
                inside,
            },
            _ => VrmShape::Plane {
                offset,
                normal: self.direction(s, "normal", &sp, Vec3::Z)?,
            },
        })
    }

    fn v0(&self, v: &Value, path: &str) -> Res<VrmSprings> {
        let root = self.object(v, path)?;
        let mut colliders = Vec::new();
        let mut groups = Vec::new();
        for (i, g) in self
            .array(root, "colliderGroups", path, MAX_VRM_GROUPS)?
            .iter()
            .enumerate()
        {
            let p = format!("{path}.colliderGroups[{i}]");
            let g = self.object(g, &p)?;
            let node = self.node_at(g, &p, "a collider group")?;
            let mut members = Vec::new();
            for (k, c) in self
                .array(g, "colliders", &p, MAX_VRM_COLLIDERS)?
                .iter()
                .enumerate()
            {
                let cp = format!("{p}.colliders[{k}]");
                let c = self.object(c, &cp)?;
                if colliders.len() >= MAX_VRM_COLLIDERS {
                    return self.err(
                        &cp,
                        format!("more than {MAX_VRM_COLLIDERS} colliders in all"),
                    );
                }
                let offset = self.vec3(c, "offset", &cp, Vec3::ZERO, MAX_VRM_COORDINATE)?;
                let radius = self.number(c, "radius", &cp, (0.0, MAX_VRM_COORDINATE), 0.0)?;
                members.push(colliders.len() as u32);
                colliders.push(VrmCollider {
                    node,
                    // Written in Unity's left-handed space: z is opposite in glTF.
                    shape: VrmShape::Sphere {
                        offset: Vec3::new(offset.x, offset.y, -offset.z),
                        radius,
                        inside: false,
                    },
                });
            }
            groups.push(members);
        }
        let mut springs = Vec::new();
        let mut total = 0usize;
        for (i, g) in self
            .array(root, "boneGroups", path, MAX_VRM_SPRINGS)?
            .iter()
            .enumerate()
        {
            let p = format!("{path}.boneGroups[{i}]");
            let g = self.object(g, &p)?;
            let name = self.name(g, "comment", &p)?;
            let bones = self.array(g, "bones", &p, MAX_VRM_GROUPS)?;
            total += bones.len();
            if total > MAX_VRM_JOINTS {
                return self.err(
                    &format!("{p}.bones"),
                    format!("more than {MAX_VRM_JOINTS} root bones in all"),
                );
            }
            let mut nodes = Vec::with_capacity(bones.len());
            for (k, b) in bones.iter().enumerate() {
                nodes.push(self.node(b, &format!("{p}.bones[{k}]"))?);
            }
            let center = match g.get("center") {
                // -1 (and absence) mean none.
                None => None,
                Some(c) if c.as_i64() == Some(-1) => None,
                Some(c) => Some(self.node(c, &format!("{p}.center"))?),
            };
            springs.push(VrmSpring {
                name,
                nodes,
                joints: vec![self.joint(g, &p, VrmVersion::V0)?],
                groups: self.group_refs(g, &p, groups.len())?,
                center,
            });
        }
        Ok(VrmSprings {
            version: VrmVersion::V0,
            colliders,
            groups,
            springs,
        })
    }
}

/// A JSON object.
mod serde_map {
    pub type Map = serde_json::Map<String, serde_json::Value>;
}

pub(super) fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}
