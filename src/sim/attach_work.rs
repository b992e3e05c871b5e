//! Whether the Attach stage's systems queued work this frame, so that the sync points between them
//! run only in frames that need them, and which of the stage's systems have anything to look at:
//! in a frame in which nothing attaches, builds or reloads, none of them runs.

use bevy::ecs::change_detection::Tick;
use bevy::ecs::system::SystemChangeTick;
use bevy::prelude::*;

use super::bone::AttachToBone;
use super::chains::{BoneChainHairs, HairBoneChains};
use super::vrm::VrmSpringChains;
use crate::asset::VrmSpringBones;

/// When the Attach stage's systems last queued work: each sync point after them runs only if
/// work was queued since it last ran, so a frame in which nothing attaches or rebuilds has none.
#[derive(Resource, Default, Debug)]
pub(crate) struct AttachWork {
    /// `attach_to_bones` looked at a hair whose bone was not settled, or `build_bone_chains`
    /// spawned hairs.
    pub(crate) bones: Tick,
    /// `build_hair_strands` built, rebuilt or reported something.
    pub(crate) strands: Tick,
}

impl AttachWork {
    /// Whether `bones` work was queued since this condition last ran.
    pub(crate) fn bones(work: Res<Self>, ticks: SystemChangeTick) -> bool {
        work.bones.is_newer_than(ticks.last_run(), ticks.this_run())
    }

    /// Whether `strands` work was queued since this condition last ran.
    pub(crate) fn strands(work: Res<Self>, ticks: SystemChangeTick) -> bool {
        work.strands
            .is_newer_than(ticks.last_run(), ticks.this_run())
    }
}

/// Run condition of `attach_to_bones`: some hair is hung on a bone by search.
pub(crate) fn attaching(hairs: Query<(), With<AttachToBone>>) -> bool {
    !hairs.is_empty()
}

/// Run condition of `build_vrm_springs`: some VRM's springs are not built yet.
pub(crate) fn vrm_springs_pending(
    roots: Query<(), (With<VrmSpringBones>, Without<VrmSpringChains>)>,
) -> bool {
    !roots.is_empty()
}

/// Run condition of `build_bone_chains`: some bone chains are not built yet.
pub(crate) fn bone_chains_pending(
    sets: Query<(), (With<HairBoneChains>, Without<BoneChainHairs>)>,
) -> bool {
    !sets.is_empty()
}
