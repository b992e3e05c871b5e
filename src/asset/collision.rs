//! `HeadCollision`: spheres, capsules and planes on a bone from a `*.collision.xml` file (format: `docs/formats.md`).

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext};
use bevy::prelude::*;

use super::error::HairAssetError;
use super::fields::{BYTES_PER_ELEMENT, length_attr, read_header, read_text};
use super::groom::{ATTRIBUTES_PER_ELEMENT, HEADER_BYTES, MARKUP_ALLOWANCE};
use super::reader::Xml;

/// Most shapes (spheres, capsules and planes together) a collision file may have.
pub const MAX_SHAPES: usize = 4096;
/// Largest collision file the loader reads: [`HEADER_BYTES`](super::HEADER_BYTES) plus 256
/// bytes per shape (about 0.1 MB plus 1 MB).
pub const COLLISION_BYTE_LIMIT: usize = HEADER_BYTES + MAX_SHAPES * BYTES_PER_ELEMENT;

/// A sphere in bone space, in metres.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
pub struct CollisionSphere {
    /// Centre in bone space.
    pub center: Vec3,
    /// Radius, `> 0`.
    pub radius: f32,
}

/// A capsule in bone space, in metres: every point within `radius` of the segment `a`-`b`.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
pub struct CollisionCapsule {
    /// One end of the axis.
    pub a: Vec3,
    /// The other end.
    pub b: Vec3,
    /// Radius, `> 0`.
    pub radius: f32,
}

/// A plane in bone space: hair stays on the side `normal` points to.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
pub struct CollisionPlane {
    /// A point on the plane.
    pub point: Vec3,
    /// The normal (normalised when used; must not be zero).
    pub normal: Vec3,
}

/// An oriented box (not in collision files: add it to a `HairCollider` in code).
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
pub struct CollisionBox {
    /// Centre.
    pub center: Vec3,
    /// Half its size along each of its axes.
    pub half_extents: Vec3,
    /// Its axes' rotation.
    pub rotation: Quat,
}

/// A head collision shape: spheres, capsules and planes in the space of one bone. Loaded from
/// `*.collision.xml`.
#[derive(Asset, TypePath, Clone, Debug, PartialEq)]
pub struct HeadCollision {
    /// The bone the shapes are relative to (empty: the entity the hair is attached to).
    pub bone: String,
    /// The spheres.
    pub spheres: Vec<CollisionSphere>,
    /// The capsules.
    pub capsules: Vec<CollisionCapsule>,
    /// The planes.
    pub planes: Vec<CollisionPlane>,
}

/// Parses the text of a `*.collision.xml` file. `file` names it in errors.
pub fn parse_collision(file: &str, input: &str) -> Result<HeadCollision, HairAssetError> {
    let mut xml = Xml::new(
        file,
        input,
        (
            2 * MAX_SHAPES + MARKUP_ALLOWANCE,
            ATTRIBUTES_PER_ELEMENT * MAX_SHAPES + MARKUP_ALLOWANCE,
        ),
    );
    let root = xml.root()?;
    let header = read_header(&xml, &root, "collision")?;
    let mut spheres = Vec::new();
    let mut capsules = Vec::new();
    let mut planes = Vec::new();
    let s = header.scale;
    let mut count = 0;
    while let Some(node) = xml.next_child_of(
        &root,
        &["sphere", "capsule", "plane"],
        "text inside <collision>; shapes are <sphere/>, <capsule/> and <plane/> elements",
    )? {
        if count >= MAX_SHAPES {
            return Err(xml.error(node.offset, format!("more than {MAX_SHAPES} shapes")));
        }
        count += 1;
        let point = |xml: &Xml, [x, y, z]: [&str; 3]| -> Result<Vec3, HairAssetError> {
            Ok(Vec3::new(
                length_attr(xml, &node, x, s)?,
                length_attr(xml, &node, y, s)?,
                length_attr(xml, &node, z, s)?,
            ))
        };
        let radius = |xml: &Xml, what: &str| -> Result<f32, HairAssetError> {
            let radius = length_attr(xml, &node, "r", s)?;
            if radius <= 0.0 {
                let at = xml.attr("r").map_or(node.offset, |a| a.offset);
                return Err(xml.error(
                    at,
                    format!("{what}: radius must be greater than 0, found {radius}"),
                ));
            }
            Ok(radius)
        };
        match node.name {
            "sphere" => {
                let center = point(&xml, ["x", "y", "z"])?;
                let radius = radius(&xml, &format!("sphere {}", spheres.len()))?;
                spheres.push(CollisionSphere { center, radius });
            }
            "capsule" => {
                let a = point(&xml, ["x0", "y0", "z0"])?;
                let b = point(&xml, ["x1", "y1", "z1"])?;
                let radius = radius(&xml, &format!("capsule {}", capsules.len()))?;
                capsules.push(CollisionCapsule { a, b, radius });
            }
            _ => {
                let at = point(&xml, ["x", "y", "z"])?;
                // A direction: not scaled, but it must have one.
                let normal = point(&xml, ["nx", "ny", "nz"])?;
                if normal.length() <= 1e-6 {
                    return Err(xml.error(
                        node.offset,
                        format!(
                            "plane {}: the normal (nx, ny, nz) must not be zero",
                            planes.len()
                        ),
                    ));
                }
                planes.push(CollisionPlane {
                    point: at,
                    normal: normal.normalize(),
                });
            }
        }
        xml.skip(&node)?;
    }
    xml.finish()?;
    if count == 0 {
        return Err(xml.error(
            root.offset,
            "the collision shape has no <sphere>, <capsule> or <plane> elements",
        ));
    }
    Ok(HeadCollision {
        bone: header.bone,
        spheres,
        capsules,
        planes,
    })
}

/// Loads [`HeadCollision`] assets from `*.collision.xml`.
#[derive(Default, TypePath)]
pub struct HeadCollisionLoader;

impl AssetLoader for HeadCollisionLoader {
    type Asset = HeadCollision;
    type Settings = ();
    type Error = HairAssetError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        load_context: &mut LoadContext<'_>,
    ) -> Result<HeadCollision, HairAssetError> {
        let file = load_context.path().to_string();
        let text = read_text(reader, &file, COLLISION_BYTE_LIMIT, "collision file").await?;
        parse_collision(&file, &text)
    }

    fn extensions(&self) -> &[&str] {
        &["collision.xml"]
    }
}
