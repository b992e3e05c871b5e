//! Hot reload: a groom, animation or collision file saved while the game runs rebuilds the hairs
//! that use it in place; a save that fails to load keeps the last version that loaded and is
//! reported.

use bevy::asset::{AssetLoadFailedEvent, UntypedAssetId};
use bevy::prelude::*;

use super::attach::{Hair, HairAssets, HairStatus, load_failure, report_failure};
use super::events::HairAssetKind;
use crate::asset::{HairAnimation, HairGroom, HeadCollision};

/// Collects the assets of `events` that were modified (reloaded).
fn modified<A: Asset>(events: &mut MessageReader<AssetEvent<A>>, out: &mut Vec<UntypedAssetId>) {
    out.extend(events.read().filter_map(|e| match e {
        AssetEvent::Modified { id } => Some(id.untyped()),
        _ => None,
    }));
}

/// Marks hairs whose groom, animation or collision file was reloaded, so they rebuild.
pub(crate) fn mark_reloaded_hairs(
    mut grooms: MessageReader<AssetEvent<HairGroom>>,
    mut animations: MessageReader<AssetEvent<HairAnimation>>,
    mut collisions: MessageReader<AssetEvent<HeadCollision>>,
    mut hairs: Query<(&Hair, &mut HairStatus)>,
) {
    let mut reloaded: Vec<UntypedAssetId> = Vec::new();
    modified(&mut grooms, &mut reloaded);
    modified(&mut animations, &mut reloaded);
    modified(&mut collisions, &mut reloaded);
    if reloaded.is_empty() {
        return;
    }
    for (hair, mut status) in &mut hairs {
        for id in asset_ids(hair).into_iter().flatten() {
            if reloaded.contains(&id.0) {
                status.reloaded = true;
                status.forget(id.0);
            }
        }
    }
}

/// The assets of a hair, with which of them each is.
fn asset_ids(hair: &Hair) -> [Option<(UntypedAssetId, HairAssetKind)>; 3] {
    [
        Some((hair.groom.id().untyped(), HairAssetKind::Groom)),
        hair.animation
            .as_ref()
            .map(|h| (h.id().untyped(), HairAssetKind::Animation)),
        hair.collision
            .as_ref()
            .map(|h| (h.id().untyped(), HairAssetKind::Collision)),
    ]
}

/// Collects `(asset, error)` of the failed loads in `events`.
fn failed<A: Asset>(
    events: &mut MessageReader<AssetLoadFailedEvent<A>>,
    out: &mut Vec<(UntypedAssetId, String)>,
) {
    out.extend(
        events
            .read()
            .map(|e| (e.id.untyped(), load_failure(&e.error))),
    );
}

/// Reports a reload that failed while the asset's last good version is still loaded (a broken
/// save): each broken save once (Bevy tries a failed reload twice), as a
/// [`HairAssetFailed`](super::HairAssetFailed) with `kept_last_good`; a save that fails with
/// the same error as the last one reported is not reported again until a save loads. The hair is left as it was. A first load that fails (nothing to keep) is
/// reported by the strand build instead.
pub(crate) fn report_failed_reloads(
    mut grooms: MessageReader<AssetLoadFailedEvent<HairGroom>>,
    mut animations: MessageReader<AssetLoadFailedEvent<HairAnimation>>,
    mut collisions: MessageReader<AssetLoadFailedEvent<HeadCollision>>,
    assets: HairAssets,
    mut hairs: Query<(Entity, &Hair, &mut HairStatus)>,
    mut commands: Commands,
) {
    let mut failures = Vec::new();
    failed(&mut grooms, &mut failures);
    failed(&mut animations, &mut failures);
    failed(&mut collisions, &mut failures);
    if failures.is_empty() {
        return;
    }
    for (entity, hair, mut status) in &mut hairs {
        for (id, kind) in asset_ids(hair).into_iter().flatten() {
            let kept = match kind {
                HairAssetKind::Groom => assets.grooms.contains(id.typed::<HairGroom>()),
                HairAssetKind::Animation => assets.animations.contains(id.typed::<HairAnimation>()),
                HairAssetKind::Collision => assets.collisions.contains(id.typed::<HeadCollision>()),
                // Not a hair asset: its failure is reported where the bone is looked up.
                HairAssetKind::Character => false,
            };
            if !kept {
                continue;
            }
            for (_, error) in failures.iter().filter(|(f, _)| *f == id) {
                // A new error is news, even a second broken save in a row; the same error again
                // before a good save is Bevy's second attempt at the same reload.
                if !status.new_failed_reload(id, error) {
                    continue;
                }
                status.allow_report(id);
                report_failure(
                    &mut commands,
                    &mut status,
                    &assets,
                    entity,
                    kind,
                    id,
                    error.clone(),
                    true,
                );
            }
        }
    }
}
