//! `airglyph devices`: the depth cameras the V4L2 and OpenNI2 backends can see.

use airglyph_capture::devices::{self, BackendListing};

/// List depth cameras (V4L2 nodes, OpenNI2 devices) with their depth modes, and what to
/// give `--source` for each.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// One JSON object a backend, a line each.
    #[arg(long)]
    json: bool,
    /// Also open these OpenNI2 URIs (e.g. Dummy, which device lists omit) and list their modes.
    #[arg(long = "openni2-uri", value_name = "URI")]
    openni2_uris: Vec<String>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    #[cfg_attr(not(feature = "openni2"), allow(unused_mut))]
    let mut listing = devices::list();
    #[cfg(feature = "openni2")]
    for uri in &args.openni2_uris {
        let modes = devices::openni2_modes(uri)?;
        if let Some(b) = listing.iter_mut().find(|b| b.backend == "openni2") {
            b.note = None;
            b.devices.push(devices::DeviceEntry {
                source: format!("openni2:{uri}"),
                name: uri.clone(),
                modes,
                other_formats: Vec::new(),
            });
        }
    }
    #[cfg(not(feature = "openni2"))]
    if let Some(uri) = args.openni2_uris.first() {
        anyhow::bail!(
            "--openni2-uri {uri}: OpenNI2 is not compiled in (build with --features openni2)"
        );
    }
    if args.json {
        for b in &listing {
            println!("{}", serde_json::to_string(b)?);
        }
    } else {
        for b in &listing {
            print_backend(b);
        }
    }
    Ok(())
}

fn print_backend(b: &BackendListing) {
    match &b.note {
        Some(note) if b.devices.is_empty() => println!("{}: {note}", b.backend),
        _ => println!("{}:", b.backend),
    }
    for d in &b.devices {
        println!("  {}  {}", d.source, d.name);
        if d.modes.is_empty() {
            println!(
                "    no depth mode{}",
                if d.other_formats.is_empty() {
                    String::new()
                } else {
                    format!(" (formats: {})", d.other_formats.join(", "))
                }
            );
        }
        for m in &d.modes {
            let fps: Vec<String> = m.fps.iter().map(|f| format!("{f}")).collect();
            println!(
                "    {}x{} {} @ {} fps",
                m.width,
                m.height,
                m.format,
                if fps.is_empty() {
                    "?".into()
                } else {
                    fps.join("/")
                }
            );
        }
    }
}
