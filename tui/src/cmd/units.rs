//! `fringe units [--rig R]`: every unit known (under the rig's profiles, the rig's own sensor,
//! and the units the simulated bench carries) with its design, its certificate (verdict, date,
//! model), its last check and verdict, the next check due and the model `fringe validate` runs
//! for it. The listing is `fringe_app::units::list`; this prints it.

use anyhow::Result;
use fringe_app::units;
use fringe_app::units::{UnitView, CHECK_EVERY_DAYS};
use fringe_app::RigConfig;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct UnitsArgs {
    /// The rig file (default: ./rig.toml if present, else the simulated bench): its profiles
    /// directory holds the units' profiles, certificates and histories.
    #[arg(long, value_name = "FILE")]
    rig: Option<PathBuf>,
}

pub fn run(a: UnitsArgs) -> Result<()> {
    let (config, source) = RigConfig::resolve(a.rig.as_deref())?;
    let list = units::list(&config, &fringe_rig::store::now_utc());
    for n in &list.notes {
        eprintln!("warning: {n}");
    }
    println!(
        "{} units known under {} (rig: {})",
        list.units.len(),
        list.profiles.display(),
        source.describe()
    );
    for u in &list.units {
        println!();
        for line in lines(u, list.on_rig.as_deref()) {
            println!("{line}");
        }
    }
    println!();
    println!(
        "a check is due {CHECK_EVERY_DAYS} days after the last one that was ok (or after the certificate); fringe check --unit ID checks one"
    );
    Ok(())
}

/// One unit's lines.
fn lines(u: &UnitView, on_rig: Option<&str>) -> Vec<String> {
    let mut about = vec![u
        .design
        .clone()
        .unwrap_or_else(|| "design not known".into())];
    if on_rig == Some(u.id.as_str()) {
        about.push("on the rig".into());
    }
    if u.simulated {
        about.push("simulated".into());
    }
    let mut out = vec![format!("{} ({})", u.id, about.join(", "))];
    out.push(match &u.certificate {
        Some(c) => format!(
            "  certificate:   {} against {}: Fz {:.2} N, contact {:.2} mm, shape {:.1} %; model {}",
            c.describe(),
            c.spec_origin,
            c.fz_rmse_n,
            c.contact_rmse_mm,
            100.0 * c.shape_accuracy,
            c.model.display()
        ),
        None => "  certificate:   none (not commissioned)".into(),
    });
    if let Some(p) = &u.passing {
        out.push(format!(
            "  last passing:  {} ({})",
            p.describe(),
            p.dir.display()
        ));
    }
    out.push(match &u.last_check {
        Some(c) => format!(
            "  last check:    {} on {} ({} {})",
            c.verdict.name(),
            fringe_app::units::when(&c.checked_utc),
            u.checks,
            if u.checks == 1 { "check" } else { "checks" }
        ),
        None => "  last check:    none".into(),
    });
    out.push(format!("  next check:    {}", u.next_check.describe()));
    out.push(format!("  validate uses: {}", u.validate.describe()));
    out
}
