//! Whether the Attach stage's systems had work this frame, so that the sync points between them
//! run only in frames that need them.

use bevy::prelude::*;

/// Whether the Attach stage's systems queued work this frame: each sync point after them runs
/// only then, so a frame in which nothing attaches or rebuilds has none.
#[derive(Resource, Default, Debug)]
pub(crate) struct AttachWork {
    /// `attach_to_bones` looked at a hair whose bone was not settled.
    pub(crate) bones: bool,
    /// `build_hair_strands` built, rebuilt or reported something.
    pub(crate) strands: bool,
}

impl AttachWork {
    pub(crate) fn bones(work: Res<Self>) -> bool {
        work.bones
    }

    pub(crate) fn strands(work: Res<Self>) -> bool {
        work.strands
    }
}
