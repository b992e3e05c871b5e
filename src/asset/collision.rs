//! `HeadCollision`: spheres on a bone from a `*.collision.xml` file (format: `docs/formats.md`).

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext};
use bevy::prelude::*;

use super::error::{HairAssetError, Locator, parse_document, read_header, read_text};

/// Most spheres a collision shape may have.
pub const MAX_SPHERES: usize = 4096;

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
    let doc = parse_document(file, input)?;
    let loc = Locator {
        file,
        doc: &doc,
        input,
    };
    let root = doc.root_element();
    let header = read_header(&loc, root, "collision")?;
    let mut spheres = Vec::new();
    for node in root.children().filter(|n| n.has_tag_name("sphere")) {
        if spheres.len() >= MAX_SPHERES {
            return Err(loc.node(node, format!("more than {MAX_SPHERES} spheres")));
        }
        let center = Vec3::new(
            loc.float_attr(node, "x")?,
            loc.float_attr(node, "y")?,
            loc.float_attr(node, "z")?,
        ) / header.scale;
        let radius = loc.float_attr(node, "r")? / header.scale;
        if radius <= 0.0 {
            return Err(loc.node(
                node,
                format!(
                    "sphere {}: radius must be greater than 0, found {radius}",
                    spheres.len()
                ),
            ));
        }
        spheres.push(CollisionSphere { center, radius });
    }
    if spheres.is_empty() {
        return Err(loc.node(root, "the collision shape has no <sphere> elements"));
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
        let text = read_text(reader, &file).await?;
        parse_collision(&file, &text)
    }

    fn extensions(&self) -> &[&str] {
        &["collision.xml"]
    }
}
