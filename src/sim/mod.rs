//! Strand simulation: hair attached to a bone, simulated with structural springs, keyframed
//! anchors and collisions (thesis 4.2).
//!
//! - [`Hair`] on the user's entity, hung on a bone with [`AttachToBone`] (by name, predicate or
//!   entity; a missing bone is a [`BoneNotFound`] error) or made a child of the bone directly.
//! - Events on the hair entity: [`HairReady`], [`HairRebuilt`], [`HairAssetFailed`],
//!   [`BoneNotFound`], [`BoneMismatch`], [`BoneScaleMismatch`], [`HairAnimationMismatch`].
//! - Any rig scale: the groom is in the bone's space and is scaled by the bone's scale when the
//!   strands are built; the solver, margins, radii and gravity work in world metres.
//! - One entity per guide strand ([`StrandOf`], [`Strand`], [`StrandParticles`]).
//! - [`HairSimSettings`] per hair: stiffnesses, anchors (S curve), gravity, damping, substeps,
//!   margins, teleport thresholds.
//! - [`ComputedHair`]: derived solver state (see `solver` for the model and memory layout).
//!
//! Systems, in `PostUpdate`:
//! 1. [`HairSystems::Attach`]: attach named bones, build strands.
//! 2. [`HairSystems::Simulate`]: step (posing bone chains), then write joints and particles out.
//!
//! # Robustness
//! Frames longer than [`HairSimSettings::max_frame_time`] are clamped; a bone that jumps farther
//! than [`HairSimSettings::teleport_distance`] (or turns more than
//! [`HairSimSettings::teleport_angle`]) carries the hair with it; a bone whose transform is not
//! finite or has zero scale is ignored for that frame (the hair waits); a strand whose state stops
//! being finite is reset onto its anchors. In debug builds a system asserts that every particle
//! written is finite.

mod attach;
mod attach_work;
mod bone;
mod chain_lanes;
mod chain_pass;
mod chain_pose;
mod chains;
mod clock;
mod collider;
mod collider_index;
#[cfg(test)]
mod collider_tests;
mod contact;
mod culling;
mod events;
mod frame_limits;
mod limits;
mod physics;
mod reload;
mod scratch;
mod segments;
mod settings;
pub mod solver;
mod step;
mod step_input;
#[cfg(test)]
mod tests;
mod volume;
mod vrm;
mod wind;
mod write_out;

pub use attach::{
    ComputedHair, Hair, HairStatus, HairStepStats, HairStrands, HeadColliderOf, Strand, StrandOf,
    StrandParticles,
};
#[cfg(feature = "render")]
pub(crate) use bone::scene_failure;
pub use bone::{AttachToBone, BonePredicate, BoneRef, BoneSearch, CharacterSpawned};
pub use chains::{BoneChainHair, BoneChainHairs, ChainSelect, HairBoneChains, MIN_TAIL};
pub use clock::{HairTime, HairTimeExt};
pub use collider::{HairCollider, HairColliderMode, HairCollidesOnly};
pub use culling::{HairCulling, HairInView};
pub use events::{
    BoneMismatch, BoneNotFound, BoneScaleMismatch, HairAnimationMismatch, HairAssetFailed,
    HairAssetKind, HairReady, HairRebuilt, RebuildReason, VrmSpringsFailed,
};
pub use limits::{ChainJointLimits, axis_rotation, limit_direction, limit_frame, limit_offset};
#[cfg(feature = "rapier")]
pub use physics::HairCollisionGroups;
#[cfg(feature = "avian")]
pub use physics::HairCollisionLayers;
pub use settings::{
    HairDampingFrame, HairInertiaFrame, HairSimSettings, MAX_MARGIN, compliance_factor,
};
pub use volume::{DEFAULT_STRAND_RADIUS, HairStrandRadius, HairVolume};
pub(crate) use volume::{VolumeScratch, keep_apart};
pub use vrm::{VRM0_TAIL, VrmSpringChains, anchor_for_rate, vrm_sim_settings};
pub use wind::{FieldStep, HairForceField, HairForceFieldKind, HairWind, HairWindOverride};

use bevy::prelude::*;

use crate::schedule::HairSystems;

/// Debug output of the simulation. Pausing and stepping the hair is [`Time<HairTime>`](Time)'s
/// job ([`HairTimeExt`]).
#[derive(Resource, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Resource, Default, Debug)]
pub struct HairSimControl {
    /// Also write the structural particles into [`StrandParticles::structural`] (for drawing
    /// springs; the debug panel turns it on). Default: `false`.
    pub write_structural: bool,
}

/// Attaches hair to bones and simulates it. Part of
/// [`CartoonHairPlugins`](crate::CartoonHairPlugins).
#[derive(Default)]
pub struct HairSimulationPlugin;

impl Plugin for HairSimulationPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<HairSimControl>()
            .init_resource::<HairWind>()
            .register_type::<HairWind>()
            .register_type::<HairVolume>()
            .register_type::<HairWindOverride>()
            .register_type::<HairForceField>()
            .init_resource::<Time<HairTime>>()
            .add_systems(
                First,
                // The hair's clock follows the virtual clock, updated just before.
                clock::advance_hair_time.after(bevy::time::TimeSystems),
            )
            .init_resource::<step::ColliderHistory>()
            .init_resource::<attach_work::AttachWork>()
            .register_type::<Hair>()
            .register_type::<HairSimSettings>()
            .register_type::<HairSimControl>()
            .register_type::<AttachToBone>()
            .register_type::<HairCollider>()
            .register_type::<HairCollidesOnly>()
            .register_type::<ComputedHair>()
            .register_type::<HairStatus>()
            .register_type::<StrandParticles>()
            .register_type::<BoneSearch>()
            .register_type::<HairBoneChains>()
            .register_type::<BoneChainHairs>()
            .register_type::<BoneChainHair>()
            .register_type::<ChainJointLimits>()
            .register_type::<HairInertiaFrame>()
            .register_type::<VrmSpringChains>()
            .add_observer(attach::detach_hair)
            .add_observer(chains::release_joints)
            .add_observer(bone::mark_spawned_characters)
            .add_systems(
                PostUpdate,
                (
                    // Each system runs only when it has something to look at (see `attach_work`).
                    bone::attach_to_bones.run_if(attach_work::attaching),
                    vrm::build_vrm_springs.run_if(attach_work::vrm_springs_pending),
                    vrm::report_failed_vrm_loads.run_if(
                        resource_exists::<Messages<bevy::asset::UntypedAssetLoadFailedEvent>>
                            .and_then(on_message::<bevy::asset::UntypedAssetLoadFailedEvent>),
                    ),
                    chains::build_bone_chains.run_if(attach_work::bone_chains_pending),
                    reload::mark_reloaded_hairs.run_if(
                        on_message::<AssetEvent<crate::asset::HairGroom>>
                            .or_eager(on_message::<AssetEvent<crate::asset::HairAnimation>>)
                            .or_eager(on_message::<AssetEvent<crate::asset::HeadCollision>>),
                    ),
                    reload::report_failed_reloads.run_if(
                        on_message::<bevy::asset::AssetLoadFailedEvent<crate::asset::HairGroom>>
                            .or_eager(
                                on_message::<
                                    bevy::asset::AssetLoadFailedEvent<crate::asset::HairAnimation>,
                                >,
                            )
                            .or_eager(
                                on_message::<
                                    bevy::asset::AssetLoadFailedEvent<crate::asset::HeadCollision>,
                                >,
                            ),
                    ),
                    // Strands are built on the bone found this frame. Each sync point runs only
                    // in frames whose systems before it queued work (see `AttachWork`).
                    ApplyDeferred.run_if(attach_work::AttachWork::bones),
                    attach::build_hair_strands.run_if(attach::hairs_to_build),
                    ApplyDeferred.run_if(attach_work::AttachWork::strands),
                )
                    .chain()
                    .in_set(HairSystems::Attach),
            )
            .add_systems(
                PostUpdate,
                (
                    step::step_hair_strands.after(physics::GatherColliders),
                    // Posing moves the particles it keeps off colliders and inside angle
                    // limits: before they are written out.
                    chain_pose::pose_bone_chains.run_if(chain_pose::hairs_left_to_pose),
                    write_out::write_hair_state.run_if(write_out::anything_left_to_write),
                    #[cfg(debug_assertions)]
                    step::assert_particles_finite,
                )
                    .chain()
                    .in_set(HairSystems::Simulate),
            );
        physics::build(app);
    }
}
