//! `HeadCollision`: spheres on a bone from a `*.collision.xml` file (format: `docs/formats.md`).

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext};
use bevy::prelude::*;

use super::error::{BYTES_PER_ELEMENT, HairAssetError, length_attr, read_header, read_text};
use super::groom::HEADER_BYTES;
use super::xml::Xml;

/// Most spheres a collision shape may have.
pub const MAX_SPHERES: usize = 4096;
/// Largest collision file the loader reads: [`HEADER_BYTES`](super::HEADER_BYTES) plus 256
/// bytes per sphere (about 0.1 MB plus 1 MB).
pub const COLLISION_BYTE_LIMIT: usize = HEADER_BYTES + MAX_SPHERES * BYTES_PER_ELEMENT;

/// A sphere in bone space, in metres.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
pub struct CollisionSphere {
    /// Centre in bone space.
    pub center: Vec3,
    /// Radius, `> 0`.
    pub radius: f32,
}

/// A head collision shape: spheres in the space of one bone. Loaded from `*.collision.xml`.
#[derive(Asset, TypePath, Clone, Debug, PartialEq)]
pub struct HeadCollision {
    /// The bone the spheres are relative to (empty: the entity the hair is attached to).
    pub bone: String,
    /// The spheres.
    pub spheres: Vec<CollisionSphere>,
}

/// Parses the text of a `*.collision.xml` file. `file` names it in errors.
pub fn parse_collision(file: &str, input: &str) -> Result<HeadCollision, HairAssetError> {
    let mut xml = Xml::new(file, input);
    let root = xml.root()?;
    let header = read_header(&xml, &root, "collision")?;
    let mut spheres = Vec::new();
    while let Some(node) = xml.next_child(
        &root,
        "sphere",
        "text inside <collision>; shapes are <sphere .../> elements",
    )? {
        let index = spheres.len();
        if index >= MAX_SPHERES {
            return Err(xml.error(node.offset, format!("more than {MAX_SPHERES} spheres")));
        }
        let s = header.scale;
        let center = Vec3::new(
            length_attr(&xml, &node, "x", s)?,
            length_attr(&xml, &node, "y", s)?,
            length_attr(&xml, &node, "z", s)?,
        );
        let radius = length_attr(&xml, &node, "r", s)?;
        if radius <= 0.0 {
            let at = xml.attr("r").map_or(node.offset, |a| a.offset);
            return Err(xml.error(
                at,
                format!("sphere {index}: radius must be greater than 0, found {radius}"),
            ));
        }
        xml.skip(&node)?;
        spheres.push(CollisionSphere { center, radius });
    }
    xml.finish()?;
    if spheres.is_empty() {
        return Err(xml.error(root.offset, "the collision shape has no <sphere> elements"));
    }
    Ok(HeadCollision {
        bone: header.bone,
        spheres,
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
