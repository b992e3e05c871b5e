//! What happens to a hair, as events a game can observe.
//!
//! Each is an [`EntityEvent`] triggered on the hair entity: watch one hair with
//! `commands.entity(hair).observe(|e: On<HairReady>| ..)`, or every hair with
//! `app.add_observer(|e: On<HairAssetFailed>| ..)`. Every failure is also logged once as an error.

use bevy::prelude::*;

/// The hair's strands were built for the first time: it is on its bone and simulating.
#[derive(EntityEvent, Clone, Debug, PartialEq)]
pub struct HairReady {
    /// The hair entity.
    pub entity: Entity,
    /// Guide strands built.
    pub strands: usize,
}

/// Why a hair was rebuilt.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Reflect)]
#[non_exhaustive]
pub enum RebuildReason {
    /// A handle on [`Hair`](super::Hair) changed, or an asset it waited for arrived.
    Assets,
    /// A groom, animation or collision file was reloaded (hot reload).
    Reloaded,
    /// The bone's scale changed (the groom is rebuilt at the new size).
    Scale,
    /// A setting that shapes the solver changed (the structure offset).
    Settings,
}

/// The hair's strands were built again; their motion restarts from the styled pose.
#[derive(EntityEvent, Clone, Debug, PartialEq)]
pub struct HairRebuilt {
    /// The hair entity.
    pub entity: Entity,
    /// What changed.
    pub reason: RebuildReason,
}

/// Which of a hair's assets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Reflect)]
#[non_exhaustive]
pub enum HairAssetKind {
    /// [`Hair::groom`](super::Hair::groom): without it there is no hair.
    Groom,
    /// [`Hair::animation`](super::Hair::animation): the hair anchors to the groom's own style.
    Animation,
    /// [`Hair::collision`](super::Hair::collision): the hair is built without a head collider.
    Collision,
    /// The scene of the character the hair hangs on (the `WorldAssetRoot` of
    /// [`AttachToBone::root`](super::AttachToBone::root) or
    /// [`HairBoneChains::root`](super::HairBoneChains::root), a glTF or VRM file): it has no
    /// bones, so the hair stays detached, or no chain is built. Triggered on the hair entity (on
    /// the [`HairBoneChains`](super::HairBoneChains) entity for chains).
    Character,
}

/// One of the hair's assets failed to load (missing file, or the loader's `file:line:col`
/// error).
#[derive(EntityEvent, Clone, Debug, PartialEq)]
pub struct HairAssetFailed {
    /// The hair entity.
    pub entity: Entity,
    /// Which asset.
    pub asset: HairAssetKind,
    /// Its path, when it was loaded from one.
    pub path: String,
    /// The loader's error.
    pub error: String,
    /// A reload of a file that had loaded failed (a broken save while the game runs): the hair
    /// keeps the last version that loaded, and a fixed save rebuilds it.
    pub kept_last_good: bool,
}

/// [`AttachToBone`](super::AttachToBone) names a bone the character does not have.
#[derive(EntityEvent, Clone, Debug, PartialEq)]
pub struct BoneNotFound {
    /// The hair entity.
    pub entity: Entity,
    /// The character searched.
    pub root: Entity,
    /// The bone asked for.
    pub bone: String,
    /// Names of the character's entities (all of them; the log lists the first 40).
    pub available: Vec<String>,
}

/// The hair hangs on a bone other than the one its groom file was exported for.
#[derive(EntityEvent, Clone, Debug, PartialEq)]
pub struct BoneMismatch {
    /// The hair entity.
    pub entity: Entity,
    /// The name of the bone it hangs on.
    pub attached: String,
    /// The `bone` attribute of the groom file.
    pub exported: String,
}

/// The groom was exported from a bone of another scale than the one it hangs on (its
/// `bone_scale` differs from the bone's world scale by more than 1%): the hair comes out
/// `bone / authored` times its authored size. Usually the character and its hair were exported
/// from different files, or the armature's scale was applied in one and not the other. The hair
/// is still built.
#[derive(EntityEvent, Clone, Debug, PartialEq)]
pub struct BoneScaleMismatch {
    /// The hair entity.
    pub entity: Entity,
    /// Metres per bone unit where the groom was made (its `bone_scale`).
    pub authored: f32,
    /// Metres per bone unit of the bone it hangs on.
    pub bone: f32,
}

/// The animation's keyframes do not match the groom's strands: the hair anchors to the groom's
/// own style.
#[derive(EntityEvent, Clone, Debug, PartialEq)]
pub struct HairAnimationMismatch {
    /// The hair entity.
    pub entity: Entity,
    /// How they differ.
    pub message: String,
}

/// A VRM character's springs are not simulated, triggered on its scene root (the entity with
/// the `WorldAssetRoot`) and logged: its spring-bone JSON could not be read (the character is
/// shown without simulated springs), it has no usable springs, or the `.vrm` file did not load
/// at all (then `error` is the loader's reason, e.g. a texture format the game's Bevy features
/// cannot decode).
///
/// A file that did not load while no scene root names it (a game that loads its avatars
/// with another VRM crate, such as bevy_vrm1) is triggered on [`Entity::PLACEHOLDER`]: observe
/// it with a global observer (`app.add_observer`).
#[derive(EntityEvent, Clone, Debug, PartialEq)]
pub struct VrmSpringsFailed {
    /// The scene root, or [`Entity::PLACEHOLDER`] when no scene root names the file.
    pub entity: Entity,
    /// The file.
    pub file: String,
    /// What is wrong (file, JSON path, what to do).
    pub error: String,
}
