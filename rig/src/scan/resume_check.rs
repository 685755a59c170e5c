//! What a resume may not change: the plan, the synchronisation, the sensor, and the rig
//! settings that make the frames (the camera, its pixel format, the simulated image scale and
//! sensor) or place them on the sensor (the geometry). A run whose second half was filmed by
//! another camera or at another size is two runs in one directory; a resume on such a rig is
//! refused before the run is touched, naming what changed and how to go on.

use crate::store::documents::StartDocument;

/// The rig file keys a resume must keep, as (table, key); `None` as key: the whole table.
const KEPT: [(&str, Option<&str>); 7] = [
    ("camera", Some("driver")),
    ("camera", Some("id")),
    ("camera", Some("pixel_format")),
    ("sim", Some("image_scale")),
    ("sim", Some("sensor")),
    ("sim", Some("sensor_file")),
    ("geometry", None),
];

/// Why the run in `dir_name` cannot be resumed with `plan`, `sync`, `sensor_id` and `rig_text`
/// (the rig file as given now); `None` when it can.
pub(crate) fn refusal(
    dir_name: &str,
    start: &StartDocument,
    plan: &str,
    sync: &str,
    sensor_id: &str,
    rig_text: &str,
) -> Option<String> {
    if start.plan != plan {
        return Some(format!(
            "{dir_name}: the run was made with a different plan; resume it with the plan stored in its {} (the `plan` field)",
            crate::store::layout::START
        ));
    }
    if start.sync_method != sync {
        return Some(format!(
            "{dir_name}: the run used sync method {}, the rig now says {sync}",
            start.sync_method
        ));
    }
    if start.sensor_id != sensor_id {
        return Some(format!(
            "{dir_name}: the run was recorded on sensor {}, the rig now names sensor {sensor_id}; resume it on the rig it was recorded with",
            start.sensor_id
        ));
    }
    let changed = changed_keys(&start.rig, rig_text);
    if changed.is_empty() {
        return None;
    }
    Some(format!(
        "{dir_name}: the rig changes what the run's frames are ({}): its frames so far were made with the rig stored in its {} (the `rig` field); resume it with that rig (save the field as a rig file and pass it with --rig), or start a new run",
        changed.join("; "),
        crate::store::layout::START
    ))
}

/// The kept keys whose values differ between the stored rig text and the rig now, each as
/// `table.key: stored -> now`. A rig text that is not TOML (older runs wrote it so when no rig
/// file was given) counts as an empty rig.
fn changed_keys(stored: &str, now: &str) -> Vec<String> {
    let parse = |t: &str| t.parse::<toml::Table>().unwrap_or_default();
    let (before, after) = (parse(stored), parse(now));
    let show = |v: Option<&toml::Value>| v.map_or("(not set)".to_string(), |v| v.to_string());
    KEPT.iter()
        .filter_map(|(table, key)| {
            let pick = |t: &toml::Table| {
                let section = t.get(*table);
                match key {
                    Some(k) => section.and_then(|s| s.get(*k)).cloned(),
                    None => section.cloned(),
                }
            };
            let (a, b) = (pick(&before), pick(&after));
            (a != b).then(|| {
                let name = key.map_or(format!("[{table}]"), |k| format!("{table}.{k}"));
                format!("{name}: {} -> {}", show(a.as_ref()), show(b.as_ref()))
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rig_that_changes_the_frames_or_their_place_is_named_key_by_key() {
        let stored = "[camera]\ndriver = \"sim\"\nframe_rate = 50.0\n[sim]\nseed = 5\n\n# devices:\n# x: ...";
        // Another frame rate or seed changes no frame's size or place.
        let same = "[camera]\ndriver = \"sim\"\nframe_rate = 25.0\n[sim]\nseed = 6\n";
        assert!(changed_keys(stored, same).is_empty());
        let smaller = "[camera]\ndriver = \"sim\"\n[sim]\nimage_scale = 0.25\n";
        assert_eq!(
            changed_keys(stored, smaller),
            vec!["sim.image_scale: (not set) -> 0.25".to_string()]
        );
        let moved =
            "[camera]\ndriver = \"sim\"\npixel_format = \"mono8\"\n[geometry]\nx_centre = 12.0\n";
        let changed = changed_keys(stored, moved);
        assert_eq!(changed.len(), 2, "{changed:?}");
        assert!(changed[0].starts_with("camera.pixel_format"));
        assert!(changed[1].starts_with("[geometry]"));
    }
}
