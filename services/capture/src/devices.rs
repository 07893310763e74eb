//! Every depth camera the compiled-in backends can see, for `airglyph devices`.

use serde::Serialize;

/// One backend's answer: its devices, or why it cannot list any.
#[derive(Debug, Clone, Serialize)]
pub struct BackendListing {
    /// `v4l2` or `openni2`.
    pub backend: &'static str,
    /// Whether this build has the backend (cargo feature of airglyph-capture).
    pub compiled: bool,
    /// Why listing failed or was not possible, if it was not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// The devices found.
    pub devices: Vec<DeviceEntry>,
}

/// A device and the depth modes it offers.
#[derive(Debug, Clone, Serialize)]
pub struct DeviceEntry {
    /// What to give `--source`: `v4l2:/dev/video2`, `openni2:1d27/0601@2/3`.
    pub source: String,
    /// Its name, as the driver or device reports it.
    pub name: String,
    /// Its depth modes.
    pub modes: Vec<ModeEntry>,
    /// Non-depth formats of the node (V4L2), for telling a colour node from a depth one.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub other_formats: Vec<String>,
}

/// A depth mode: size, rates and pixel format.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeEntry {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Frame rates; several for V4L2 sizes.
    pub fps: Vec<f32>,
    /// The pixel format's name.
    pub format: String,
}

/// Lists the devices of every backend (compiled in or not, so the output says which).
pub fn list() -> Vec<BackendListing> {
    vec![list_v4l2(), list_openni2()]
}

#[cfg(feature = "v4l2")]
fn list_v4l2() -> BackendListing {
    let devices = crate::v4l2::list_devices()
        .into_iter()
        .map(|l| DeviceEntry {
            source: format!("v4l2:{}", l.path.display()),
            name: format!("{} ({})", l.card, l.driver),
            modes: l
                .depth_modes
                .iter()
                .map(|m| ModeEntry {
                    width: m.width,
                    height: m.height,
                    fps: m.fps.clone(),
                    format: m.format.name().to_owned(),
                })
                .collect(),
            other_formats: l.other_formats,
        })
        .collect::<Vec<_>>();
    BackendListing {
        backend: "v4l2",
        compiled: true,
        note: crate::v4l2::device_nodes()
            .is_empty()
            .then(|| "no /dev/video* device on this machine".to_owned()),
        devices,
    }
}

#[cfg(not(feature = "v4l2"))]
fn list_v4l2() -> BackendListing {
    BackendListing {
        backend: "v4l2",
        compiled: false,
        note: Some("not compiled in: build with --features v4l2".into()),
        devices: Vec::new(),
    }
}

#[cfg(feature = "openni2")]
fn list_openni2() -> BackendListing {
    match crate::openni2::list_devices() {
        Ok(list) => BackendListing {
            backend: "openni2",
            compiled: true,
            note: list.is_empty().then(|| {
                "no device connected (openni2:Dummy is OpenNI2's test device, openni2:FILE.oni plays a recording)"
                    .to_owned()
            }),
            devices: list
                .into_iter()
                .map(|d| DeviceEntry {
                    source: format!("openni2:{}", d.uri),
                    name: format!("{} {}", d.vendor, d.name),
                    modes: d
                        .depth_modes
                        .iter()
                        .map(|m| ModeEntry {
                            width: m.width,
                            height: m.height,
                            fps: vec![m.fps as f32],
                            format: m.format.to_owned(),
                        })
                        .collect(),
                    other_formats: Vec::new(),
                })
                .collect(),
        },
        Err(e) => BackendListing {
            backend: "openni2",
            compiled: true,
            note: Some(e.to_string()),
            devices: Vec::new(),
        },
    }
}

#[cfg(not(feature = "openni2"))]
fn list_openni2() -> BackendListing {
    BackendListing {
        backend: "openni2",
        compiled: false,
        note: Some("not compiled in: build with --features openni2".into()),
        devices: Vec::new(),
    }
}

/// The modes of one OpenNI2 device by URI (e.g. `Dummy`, which `list` cannot see).
#[cfg(feature = "openni2")]
pub fn openni2_modes(uri: &str) -> Result<Vec<ModeEntry>, crate::SourceError> {
    Ok(crate::openni2::depth_modes_of(uri)?
        .into_iter()
        .map(|m| ModeEntry {
            width: m.width,
            height: m.height,
            fps: vec![m.fps as f32],
            format: m.format.to_owned(),
        })
        .collect())
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_backend_answers_even_without_devices() {
        let l = super::list();
        assert_eq!(
            l.iter().map(|b| b.backend).collect::<Vec<_>>(),
            ["v4l2", "openni2"]
        );
        for b in &l {
            assert!(b.compiled || b.note.as_deref().unwrap_or("").contains("--features"));
        }
    }
}
