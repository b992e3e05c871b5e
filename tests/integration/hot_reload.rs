//! Hot reload as a modder meets it: groom and collision files rewritten on disk while the hair
//! runs (good, broken, then restored), through Bevy's real asset server.

use std::path::Path;
use std::time::Duration;

use bevy::asset::AssetPlugin;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_cartoon_hair::HairSchedulePlugin;
use bevy_cartoon_hair::asset::{HairAssetPlugin, HairGroom, HeadCollision};
use bevy_cartoon_hair::sim::{
    HairAssetFailed, HairCollider, HairReady, HairRebuilt, HairSimSettings, HairSimulationPlugin,
    HeadColliderOf, Strand, StrandParticles,
};
use libtest_mimic::Failed;

/// Tests that need no GPU.
pub const TESTS: &[(&str, crate::TestFn)] = &[(
    "saved_good_broken_and_restored_files_rebuild_keep_and_recover_the_hair",
    saved_good_broken_and_restored_files_rebuild_keep_and_recover_the_hair,
)];

/// What the hair reported, in order.
#[derive(Resource, Default)]
struct Seen(Vec<String>);

fn groom_text(strands: usize) -> String {
    let mut s = String::from("<groom version=\"1\" bone=\"\">\n");
    for i in 0..strands {
        let x = i as f32 * 0.01;
        s += &format!("  <strand>{x} 0.1 0  {x} 0.15 0.01  {x} 0.2 0.03</strand>\n");
    }
    s + "</groom>\n"
}

fn collision_text(spheres: usize) -> String {
    let mut s = String::from("<collision version=\"1\" bone=\"\">\n");
    for i in 0..spheres {
        s += &format!(
            "  <sphere x=\"0\" y=\"{}\" z=\"0\" r=\"0.08\"/>\n",
            i as f32 * 0.02
        );
    }
    s + "</collision>\n"
}

fn app(root: &Path) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin {
            file_path: root.display().to_string(),
            ..default()
        },
        HairAssetPlugin,
        HairSchedulePlugin,
        HairSimulationPlugin,
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )))
    .init_resource::<Seen>()
    .add_observer(|e: On<HairReady>, mut seen: ResMut<Seen>| {
        seen.0.push(format!("ready {}", e.strands));
    })
    .add_observer(|e: On<HairRebuilt>, mut seen: ResMut<Seen>| {
        seen.0.push(format!("rebuilt {:?}", e.reason));
    })
    .add_observer(|e: On<HairAssetFailed>, mut seen: ResMut<Seen>| {
        seen.0.push(format!(
            "failed {:?} kept={} {}",
            e.asset, e.kept_last_good, e.error
        ));
    });
    app
}

/// Updates until the hair reported something new, then 20 frames more (Bevy tries a failed
/// reload twice: a second report would come in them); returns the one report.
fn next_report(app: &mut App, what: &str) -> Result<String, Failed> {
    let before = app.world().resource::<Seen>().0.len();
    for _ in 0..3000 {
        app.update();
        if app.world().resource::<Seen>().0.len() > before {
            for _ in 0..20 {
                app.update();
                std::thread::sleep(Duration::from_millis(2));
            }
            let seen = &app.world().resource::<Seen>().0[before..];
            if seen.len() != 1 {
                return Err(
                    format!("{what}: {} reports, one expected: {seen:#?}", seen.len()).into(),
                );
            }
            return Ok(seen[0].clone());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    Err(format!("no report after {what}").into())
}

fn strands(app: &mut App) -> Vec<Vec<Vec3>> {
    let mut q = app.world_mut().query::<(&Strand, &StrandParticles)>();
    let mut v: Vec<_> = q
        .iter(app.world())
        .map(|(s, p)| (s.index, p.positions.clone()))
        .collect();
    v.sort_by_key(|(i, _)| *i);
    v.into_iter().map(|(_, p)| p).collect()
}

fn head_spheres(app: &mut App) -> Vec<usize> {
    let mut q = app.world_mut().query::<(&HairCollider, &HeadColliderOf)>();
    q.iter(app.world()).map(|(c, _)| c.spheres.len()).collect()
}

fn check(ok: bool, what: impl Into<String>) -> Result<(), Failed> {
    if ok { Ok(()) } else { Err(what.into().into()) }
}

fn saved_good_broken_and_restored_files_rebuild_keep_and_recover_the_hair() -> Result<(), Failed> {
    let dir = std::env::temp_dir().join(format!("hair_hot_reload_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    let groom_file = dir.join("h.hair.xml");
    let collision_file = dir.join("h.collision.xml");
    std::fs::write(&groom_file, groom_text(4))?;
    std::fs::write(&collision_file, collision_text(1))?;

    let mut app = app(&dir);
    let server = app.world().resource::<AssetServer>().clone();
    let tuned = HairSimSettings {
        damping: 0.37,
        ..default()
    };
    let bone = app
        .world_mut()
        .spawn(Transform::from_xyz(0.0, 1.6, 0.0))
        .id();
    let hair = app
        .world_mut()
        .spawn((
            bevy_cartoon_hair::sim::Hair {
                groom: server.load("h.hair.xml"),
                animation: None,
                collision: Some(server.load("h.collision.xml")),
            },
            tuned.clone(),
            ChildOf(bone),
        ))
        .id();
    check(
        next_report(&mut app, "the first load")? == "ready 4",
        "the hair was not built",
    )?;
    check(head_spheres(&mut app) == [1], "one head sphere")?;

    // A good save with more strands rebuilds the hair in place.
    std::fs::write(&groom_file, groom_text(6))?;
    server.reload("h.hair.xml");
    let r = next_report(&mut app, "a good save")?;
    check(r == "rebuilt Reloaded", format!("a good save: {r}"))?;
    check(strands(&mut app).len() == 6, "the saved groom's 6 strands")?;
    check(
        app.world().get::<HairSimSettings>(hair) == Some(&tuned),
        "the tuning was kept",
    )?;
    check(
        app.world().get::<ChildOf>(hair).map(ChildOf::parent) == Some(bone),
        "the attachment was kept",
    )?;

    // A broken save: reported with its line, the last good hair kept and still simulated.
    let mut broken = groom_text(6);
    broken = broken.replacen("0.15", "NaN", 1);
    std::fs::write(&groom_file, &broken)?;
    server.reload("h.hair.xml");
    let r = next_report(&mut app, "a broken save")?;
    println!("broken groom save: {r}");
    check(
        r.starts_with("failed Groom kept=true") && r.contains("h.hair.xml:2:"),
        format!("a broken save must be reported with its line: {r}"),
    )?;
    for _ in 0..30 {
        app.update();
    }
    let kept = strands(&mut app);
    check(kept.len() == 6, "the last good hair stays")?;
    check(
        kept.iter().flatten().all(|p| p.is_finite()),
        "the kept hair is finite",
    )?;
    check(
        app.world().resource::<Assets<HairGroom>>().len() == 1,
        "the last good groom stays loaded",
    )?;

    // A second broken save in a row is reported too.
    std::fs::write(&groom_file, broken.replacen("<strand>", "<strand><b/>", 1))?;
    server.reload("h.hair.xml");
    let r = next_report(&mut app, "a second broken save")?;
    check(
        r.starts_with("failed Groom kept=true") && r.contains("element <b>"),
        format!("the second broken save: {r}"),
    )?;

    // The fixed save recovers.
    std::fs::write(&groom_file, groom_text(4))?;
    server.reload("h.hair.xml");
    let r = next_report(&mut app, "the fixed save")?;
    check(r == "rebuilt Reloaded", format!("the fixed save: {r}"))?;
    check(strands(&mut app).len() == 4, "the fixed groom's 4 strands")?;

    // The collision file: broken keeps the head, fixed rebuilds it.
    std::fs::write(
        &collision_file,
        collision_text(1).replace("r=\"0.08\"", "r=\"-1\""),
    )?;
    server.reload("h.collision.xml");
    let r = next_report(&mut app, "a broken collision save")?;
    println!("broken collision save: {r}");
    check(
        r.starts_with("failed Collision kept=true") && r.contains("h.collision.xml:2:"),
        format!("a broken collision save: {r}"),
    )?;
    check(
        head_spheres(&mut app) == [1],
        "the head collider stays as it was",
    )?;
    check(
        app.world().resource::<Assets<HeadCollision>>().len() == 1,
        "the last good collision stays loaded",
    )?;
    std::fs::write(&collision_file, collision_text(2))?;
    server.reload("h.collision.xml");
    let r = next_report(&mut app, "the fixed collision save")?;
    check(
        r == "rebuilt Reloaded",
        format!(
            "the fixed collision: {r}; all reports: {:#?}",
            app.world().resource::<Seen>().0
        ),
    )?;
    for _ in 0..3 {
        app.update();
    }
    check(
        head_spheres(&mut app) == [2],
        format!(
            "the fixed collision's 2 spheres: {:?}",
            head_spheres(&mut app)
        ),
    )?;
    check(
        strands(&mut app).iter().flatten().all(|p| p.is_finite()),
        "finite after every reload",
    )?;
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}
