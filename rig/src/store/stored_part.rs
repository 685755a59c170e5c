//! What a scan stores of each frame: the `[recording]` section that a rig file and a scan plan
//! both may hold. A plan's keys take precedence over the rig file's, key by key, so a plan can
//! ask for only the disc's square (a long commissioning or dataset scan) on a rig that stores
//! whole frames, and the run's start document keeps the plan that said so.

use super::frames::{FrameCodec, DISC_MARGIN_PX};

/// `[recording]` as written in a rig file or a plan.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecordingSection {
    /// `frame` (default): whole frames; `disc`: only the square around the sensor's disc (from
    /// its calibration profile), widened by `disc_margin_px`. Calibration scans always store
    /// whole frames.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub store: Option<String>,
    /// Margin around the disc, px (default 40): room for the disc to move a little in the image
    /// (a knocked camera) before the profile is redone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub disc_margin_px: Option<f64>,
    /// `fgl` (the default for one-channel frames, bayerrg8 and mono8): fringe's own lossless
    /// codec, about 11 % fewer bytes than PNG at less CPU to write; `png` (the default for
    /// rgb8): PNG files, read by any tool.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub codec: Option<String>,
}

/// The part of each frame a scan stores.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StoredPart {
    Frame,
    Disc { margin_px: f64 },
}

impl RecordingSection {
    /// These keys where given, `base`'s where not (a plan's section over the rig file's).
    pub fn over(&self, base: &RecordingSection) -> RecordingSection {
        RecordingSection {
            store: self.store.clone().or_else(|| base.store.clone()),
            disc_margin_px: self.disc_margin_px.or(base.disc_margin_px),
            codec: self.codec.clone().or_else(|| base.codec.clone()),
        }
    }

    /// The codec the keys ask for (`None`: the default for the camera's pixel format); the
    /// error names the key and what to write instead.
    pub fn codec(&self) -> Result<Option<FrameCodec>, String> {
        match self.codec.as_deref() {
            None => Ok(None),
            Some("png") => Ok(Some(FrameCodec::Png)),
            Some("fgl") => Ok(Some(FrameCodec::Fgl)),
            Some(other) => Err(format!(
                "key `recording.codec` = {other:?}: use \"fgl\" (fringe's own codec, the \
                 default for bayerrg8 and mono8) or \"png\" (PNG files, read by any tool)"
            )),
        }
    }

    /// The part the keys ask for; the error names the key and what to write instead.
    pub fn stored_part(&self) -> Result<StoredPart, String> {
        let margin_px = self.disc_margin_px.unwrap_or(DISC_MARGIN_PX);
        if !(margin_px.is_finite() && (0.0..=1000.0).contains(&margin_px)) {
            return Err(format!(
                "key `recording.disc_margin_px` = {margin_px}: use a margin from 0 to 1000 px"
            ));
        }
        match self.store.as_deref() {
            None | Some("frame") => Ok(StoredPart::Frame),
            Some("disc") => Ok(StoredPart::Disc { margin_px }),
            Some(other) => Err(format!(
                "key `recording.store` = {other:?}: use \"frame\" (whole frames) or \"disc\" (the \
                 square around the sensor's disc)"
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section(store: Option<&str>, margin: Option<f64>) -> RecordingSection {
        RecordingSection {
            store: store.map(str::to_string),
            disc_margin_px: margin,
            codec: None,
        }
    }

    #[test]
    fn a_plan_overrides_the_rig_file_key_by_key() {
        let rig = section(Some("frame"), Some(12.0));
        assert_eq!(
            section(Some("disc"), None).over(&rig).stored_part(),
            Ok(StoredPart::Disc { margin_px: 12.0 })
        );
        assert_eq!(
            section(None, Some(60.0))
                .over(&section(Some("disc"), None))
                .stored_part(),
            Ok(StoredPart::Disc { margin_px: 60.0 })
        );
        assert_eq!(
            RecordingSection::default().over(&rig).stored_part(),
            Ok(StoredPart::Frame)
        );
        assert_eq!(
            section(Some("disc"), None).stored_part(),
            Ok(StoredPart::Disc {
                margin_px: DISC_MARGIN_PX
            })
        );
    }

    #[test]
    fn bad_values_are_refused_naming_the_key() {
        let e = section(Some("crop"), None)
            .stored_part()
            .expect_err("store");
        assert!(
            e.contains("recording.store") && e.contains("\"disc\""),
            "{e}"
        );
        let e = RecordingSection {
            codec: Some("jpeg".into()),
            ..RecordingSection::default()
        }
        .codec()
        .expect_err("codec");
        assert!(
            e.contains("recording.codec") && e.contains("\"fgl\""),
            "{e}"
        );
        let fgl = RecordingSection {
            codec: Some("fgl".into()),
            ..RecordingSection::default()
        };
        assert_eq!(
            section(None, None).over(&fgl).codec(),
            Ok(Some(FrameCodec::Fgl))
        );
        assert_eq!(section(None, None).codec(), Ok(None));
        for m in [-1.0, 1e4, f64::NAN] {
            let e = section(Some("disc"), Some(m))
                .stored_part()
                .expect_err("margin");
            assert!(e.contains("recording.disc_margin_px"), "{e}");
        }
    }
}
