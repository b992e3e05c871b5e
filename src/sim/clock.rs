//! The hair's own clock, `Time<HairTime>`: pause and single-step the hair (and only the hair)
//! the way Bevy pauses `Time<Virtual>`.

use std::time::Duration;

use bevy::prelude::*;

/// The context of the hair's clock, [`Time<HairTime>`](Time). It follows `Time<Virtual>` (so
/// pausing the game pauses the hair too); on top of that the hair can be paused alone and
/// stepped by [`HairTime::step_seconds`] at a time while paused.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cartoon_hair::sim::{HairTime, HairTimeExt};
/// fn toggle(keys: Res<ButtonInput<KeyCode>>, mut hair_time: ResMut<Time<HairTime>>) {
///     if keys.just_pressed(KeyCode::KeyP) {
///         hair_time.toggle_pause();
///     }
///     if keys.just_pressed(KeyCode::Enter) {
///         hair_time.step_once();
///     }
/// }
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct HairTime {
    paused: bool,
    /// Seconds one [`HairTimeExt::step_once`] advances. Default: `1/60`.
    step: f32,
    /// Steps asked for and not yet taken.
    pending: u32,
}

impl Default for HairTime {
    fn default() -> Self {
        Self {
            paused: false,
            step: 1.0 / 60.0,
            pending: 0,
        }
    }
}

impl HairTime {
    /// Seconds one step advances.
    pub fn step_seconds(&self) -> f32 {
        self.step
    }
}

/// Pause and step controls of [`Time<HairTime>`](Time).
pub trait HairTimeExt {
    /// Stops the hair; the rest of the game goes on.
    fn pause(&mut self);
    /// Lets the hair run again.
    fn unpause(&mut self);
    /// Pauses or unpauses.
    fn toggle_pause(&mut self);
    /// Whether the hair is paused.
    fn is_paused(&self) -> bool;
    /// Advances the paused hair by one step next frame (running hair ignores it).
    fn step_once(&mut self);
    /// Sets the seconds one step advances: finite and in `(0, 1]`, else ignored with a warning
    /// (a NaN step would freeze the hair's animation clock for good).
    fn set_step_seconds(&mut self, seconds: f32);
}

impl HairTimeExt for Time<HairTime> {
    fn pause(&mut self) {
        self.context_mut().paused = true;
    }
    fn unpause(&mut self) {
        self.context_mut().paused = false;
    }
    fn toggle_pause(&mut self) {
        let c = self.context_mut();
        c.paused = !c.paused;
    }
    fn is_paused(&self) -> bool {
        self.context().paused
    }
    fn step_once(&mut self) {
        let c = self.context_mut();
        if c.paused {
            c.pending = c.pending.saturating_add(1);
        }
    }
    fn set_step_seconds(&mut self, seconds: f32) {
        if seconds.is_finite() && seconds > 0.0 && seconds <= 1.0 {
            self.context_mut().step = seconds;
        } else {
            warn!("hair step of {seconds} s ignored: it must be finite and in (0, 1]");
        }
    }
}

/// Advances `Time<HairTime>` by the frame's virtual time, nothing while paused, or one step per
/// frame while steps are pending.
pub(crate) fn advance_hair_time(virt: Res<Time<Virtual>>, mut hair: ResMut<Time<HairTime>>) {
    let c = *hair.context();
    let dt = if !c.paused {
        virt.delta()
    } else if c.pending > 0 {
        hair.context_mut().pending -= 1;
        Duration::from_secs_f32(c.step)
    } else {
        Duration::ZERO
    };
    hair.advance_by(dt);
}
