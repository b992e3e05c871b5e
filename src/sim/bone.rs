//! Hanging a hair on a bone of a character: [`AttachToBone`], the bone lookup and its errors.
//!
//! The user builds the hair entity with everything on it ([`Hair`](super::Hair), settings,
//! material, their own components) and adds [`AttachToBone`]. Once the bone exists the plugin
//! makes the hair entity a child of it ([`ChildOf`]); nothing else on the entity changes. A glTF
//! character spawns asynchronously: while its root carries a `WorldAssetRoot` whose instance is
//! not ready yet, the search waits; after that, a bone that is not there is an error (a log line
//! naming the bone, the character and the bones it has, and a [`BoneNotFound`] event). A scene
//! that fails to load (a wrong path, a broken file, a texture Bevy cannot decode) ends the wait:
//! a log line naming the file and the loader's reason, and a [`HairAssetFailed`] of
//! [`HairAssetKind::Character`].

use std::sync::Arc;

use bevy::prelude::*;
use bevy::world_serialization::{WorldAssetRoot, WorldInstanceReady};

use super::events::{BoneNotFound, HairAssetFailed, HairAssetKind};

/// Which bone of a character a hair hangs on.
#[derive(Clone, Debug, Reflect)]
#[reflect(Clone, Debug)]
#[non_exhaustive]
pub enum BoneRef {
    /// The character's descendant (or the root itself) with this [`Name`]: a glTF node name such
    /// as `"head"` or `"mixamorig:Head"`.
    Name(String),
    /// This entity, whatever its name.
    Entity(Entity),
    /// The first descendant, depth first, whose [`Name`] the predicate accepts.
    Matching(#[reflect(ignore)] BonePredicate),
}

/// A test on a bone's name.
type NameTest = dyn Fn(&str) -> bool + Send + Sync;

/// A test on a bone's name, for [`BoneRef::Matching`].
#[derive(Clone, Default)]
pub struct BonePredicate(Option<Arc<NameTest>>);

impl BonePredicate {
    /// Wraps a test on a bone's name.
    pub fn new(test: impl Fn(&str) -> bool + Send + Sync + 'static) -> Self {
        Self(Some(Arc::new(test)))
    }

    /// Whether `name` passes (an empty predicate passes nothing).
    pub fn matches(&self, name: &str) -> bool {
        self.0.as_ref().is_some_and(|f| f(name))
    }
}

impl std::fmt::Debug for BonePredicate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("BonePredicate(..)")
    }
}

impl std::fmt::Display for BoneRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Name(n) => write!(f, "bone named {n:?}"),
            Self::Entity(e) => write!(f, "bone entity {e}"),
            Self::Matching(_) => f.write_str("bone matching a predicate"),
        }
    }
}

/// Hangs the hair on this entity on a bone of a character: the plugin finds the bone (waiting
/// for a glTF scene to spawn) and makes this entity its child. Every component on the entity
/// stays. This entity's [`Transform`] is then relative to the bone (identity: the groom sits as
/// exported).
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_cartoon_hair::prelude::*;
/// # fn setup(mut commands: Commands, character: Entity, hair: Hair) {
/// commands.spawn((hair, AttachToBone::named(character, "mixamorig:Head")));
/// # }
/// ```
#[derive(Component, Reflect, Clone, Debug)]
#[reflect(Component, Debug)]
pub struct AttachToBone {
    /// The character: the entity whose descendants are searched (a glTF scene root).
    pub root: Entity,
    /// Which bone.
    pub bone: BoneRef,
}

impl AttachToBone {
    /// The descendant of `root` named `bone`.
    pub fn named(root: Entity, bone: impl Into<String>) -> Self {
        Self {
            root,
            bone: BoneRef::Name(bone.into()),
        }
    }

    /// The bone entity itself.
    pub fn entity(bone: Entity) -> Self {
        Self {
            root: bone,
            bone: BoneRef::Entity(bone),
        }
    }

    /// The first descendant of `root` whose name passes `test`, e.g. one ending in `"Head"`.
    pub fn matching(root: Entity, test: impl Fn(&str) -> bool + Send + Sync + 'static) -> Self {
        Self {
            root,
            bone: BoneRef::Matching(BonePredicate::new(test)),
        }
    }
}

/// Where a hair's bone search stands. Derived from [`AttachToBone`]; changing that component
/// searches again.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq)]
#[reflect(Component, Debug, PartialEq)]
#[non_exhaustive]
pub enum BoneSearch {
    /// The character's scene has not spawned yet.
    Waiting,
    /// Attached to this bone.
    Found(Entity),
    /// Not there; reported once with [`BoneNotFound`].
    NotFound,
}

/// Marks a character root whose glTF world instance has spawned.
#[derive(Component, Reflect, Clone, Copy, Debug, Default)]
#[reflect(Component, Debug, Default)]
pub struct CharacterSpawned;

/// Marks a root whose scene instance became ready, so bone searches under it can decide.
pub(crate) fn mark_spawned_characters(ready: On<WorldInstanceReady>, mut commands: Commands) {
    if let Ok(mut root) = commands.get_entity(ready.entity) {
        root.try_insert(CharacterSpawned);
    }
}

/// Most bone names an error lists.
const LISTED_BONES: usize = 40;

/// Resolves [`AttachToBone`]: parents the hair to its bone, or reports the bone missing.
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(crate) fn attach_to_bones(
    mut commands: Commands,
    (mut work, ticks): (
        ResMut<super::attach_work::AttachWork>,
        bevy::ecs::system::SystemChangeTick,
    ),
    hairs: Query<(
        Entity,
        Ref<AttachToBone>,
        Option<&BoneSearch>,
        Option<&ChildOf>,
    )>,
    roots: Query<(Option<&WorldAssetRoot>, Has<CharacterSpawned>)>,
    children: Query<&Children>,
    (names, exists, server): (Query<&Name>, Query<()>, Option<Res<AssetServer>>),
) {
    for (hair, attach, search, parent) in &hairs {
        let decided = matches!(search, Some(BoneSearch::Found(_) | BoneSearch::NotFound));
        if decided && !attach.is_changed() {
            continue;
        }
        // This hair may queue commands: the sync point after this system runs this frame.
        work.bones = ticks.this_run();
        let found = match &attach.bone {
            BoneRef::Entity(e) => exists.contains(*e).then_some(*e),
            by_name => {
                let Ok((scene, spawned)) = roots.get(attach.root) else {
                    report(&mut commands, hair, &attach, &names, &children, true);
                    continue;
                };
                let matches = |e: &Entity| {
                    names.get(*e).is_ok_and(|n| match by_name {
                        BoneRef::Name(want) => n.as_str() == want,
                        BoneRef::Matching(p) => p.matches(n.as_str()),
                        BoneRef::Entity(_) => false,
                    })
                };
                let found = std::iter::once(attach.root)
                    .chain(children.iter_descendants(attach.root))
                    .find(matches);
                if found.is_none()
                    && let Some(scene) = scene
                    && !spawned
                {
                    if let Some((file, reason)) = scene_failure(server.as_deref(), scene) {
                        report_scene_failure(
                            &mut commands,
                            (hair, "hair", "the hair stays detached"),
                            attach.root,
                            file,
                            reason,
                        );
                        commands.entity(hair).insert(BoneSearch::NotFound);
                        continue;
                    }
                    if search != Some(&BoneSearch::Waiting) {
                        commands.entity(hair).insert(BoneSearch::Waiting);
                    }
                    continue;
                }
                found
            }
        };
        match found {
            Some(bone) => {
                if parent.is_none_or(|p| p.parent() != bone) {
                    commands.entity(hair).insert(ChildOf(bone));
                }
                commands.entity(hair).insert(BoneSearch::Found(bone));
            }
            None => report(&mut commands, hair, &attach, &names, &children, false),
        }
    }
}

/// The file of a character's scene and the loader's reason, if the scene failed to load.
pub(crate) fn scene_failure(
    server: Option<&AssetServer>,
    scene: &WorldAssetRoot,
) -> Option<(String, String)> {
    let Some(bevy::asset::LoadState::Failed(error)) = server?.get_load_state(scene.0.id()) else {
        return None;
    };
    let file = scene.0.path().map_or_else(
        || format!("{:?}", scene.0.id()),
        |p| p.without_label().to_string(),
    );
    let reason = super::attach::load_failure(&error);
    Some((file, reason.lines().next().unwrap_or_default().to_string()))
}

/// Reports that the scene `file` of `character`, which `entity` (a hair, or a set of bone
/// chains) waited on, did not load: an error in the log saying what is left undone
/// (`consequence`) and a [`HairAssetFailed`].
pub(super) fn report_scene_failure(
    commands: &mut Commands,
    (entity, what, consequence): (Entity, &str, &str),
    character: Entity,
    file: String,
    reason: String,
) {
    error!(
        "{what} {entity}: the scene {file:?} of its character {character} did not load, so \
         there are no bones ({consequence}): {reason}. Fix the file or its path"
    );
    commands.trigger(HairAssetFailed {
        entity,
        asset: HairAssetKind::Character,
        path: file,
        error: reason,
        kept_last_good: false,
    });
}

/// The names of `root` and its descendants, depth first: what a missing-bone error lists.
pub(super) fn names_under(
    root: Entity,
    names: &Query<&Name>,
    children: &Query<&Children>,
) -> Vec<String> {
    std::iter::once(root)
        .chain(children.iter_descendants(root))
        .filter_map(|e| names.get(e).ok().map(|n| n.as_str().to_string()))
        .collect()
}

fn report(
    commands: &mut Commands,
    hair: Entity,
    attach: &AttachToBone,
    names: &Query<&Name>,
    children: &Query<&Children>,
    root_missing: bool,
) {
    let character = names.get(attach.root).map_or_else(
        |_| format!("{}", attach.root),
        |n| format!("{n:?} ({})", attach.root),
    );
    let available: Vec<String> = if root_missing {
        Vec::new()
    } else {
        names_under(attach.root, names, children)
    };
    let shown = available
        .iter()
        .take(LISTED_BONES)
        .map(|n| format!("{n:?}"))
        .collect::<Vec<_>>()
        .join(", ");
    let more = available.len().saturating_sub(LISTED_BONES);
    let hint = match &attach.bone {
        BoneRef::Name(n) if n.contains(':') || available.iter().any(|a| a.contains(':')) => {
            " (names with a prefix such as `mixamorig:` must match whole; try \
             AttachToBone::matching to match a suffix)"
        }
        _ => "",
    };
    if root_missing {
        error!(
            "hair {hair}: the character {character} of AttachToBone does not exist; the hair \
             stays detached"
        );
    } else {
        error!(
            "hair {hair}: no {} under the character {character}; it has {} named entities: \
             {shown}{}{hint}. Fix AttachToBone::bone; the hair stays detached",
            attach.bone,
            available.len(),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            },
        );
    }
    commands.entity(hair).insert(BoneSearch::NotFound);
    commands.trigger(BoneNotFound {
        entity: hair,
        root: attach.root,
        bone: attach.bone.to_string(),
        available,
    });
}
