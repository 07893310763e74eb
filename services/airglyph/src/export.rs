//! `airglyph run --export zenoh`: `airglyph-zenoh export` started beside the stages, as a
//! companion of the supervisor (`airglyph::supervisor::CompanionPlan`), so one command
//! on the device both runs the pipeline and carries its messages to another host.
//!
//! `airglyph-zenoh` is a program of its own, not a subcommand: Zenoh takes a quarter
//! of an hour to build on two cores (services/zenoh/NOTES.md), and a device that does
//! not export should not pay for it. So it is looked up at start, beside this
//! executable (where `cargo build` and `cargo install` put both) and then on PATH, and a
//! pipeline that cannot find it is refused before any stage starts.

use airglyph::supervisor::CompanionPlan;
use anyhow::bail;
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// Where `run --help` lists the options.
const HEADING: &str = "Export to another host";

/// The exporter's executable.
pub const PROGRAM: &str = "airglyph-zenoh";

/// Where `--export` carries the pipeline's messages.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Export {
    /// `airglyph-zenoh export`: gestures, decisions, skeletons and stats over Zenoh
    /// (TCP), for `airglyph-zenoh import` on the other host.
    Zenoh,
}

/// The export options of `airglyph run`. They are the exporter's own `--listen`,
/// `--connect` and `--domain` with `export-` in front, handed over as they are; the
/// pipeline's root and prefix it gets from the supervisor, as every stage does.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ExportArgs {
    /// Also carry the pipeline's gestures, decisions, skeletons and stats to another
    /// host: `zenoh` starts `airglyph-zenoh export` once the stages run, supervised as
    /// they are (restarted after its backoff, stopped with them), except that an
    /// exporter that keeps dying is given up alone and the pipeline runs on. It is
    /// looked up beside this executable, then on PATH (build it with `cargo build
    /// --release -p airglyph-zenoh`). The other host runs `airglyph-zenoh import
    /// --connect tcp/DEVICE:7447`. Needs --export-listen or --export-connect.
    #[arg(long, help_heading = HEADING, value_enum, value_name = "TO")]
    pub export: Option<Export>,
    /// With --export: a Zenoh endpoint the exporter listens on, for the other host to
    /// connect to, e.g. tcp/0.0.0.0:7447 (repeat for more). The link has no
    /// authentication and no encryption: listen on a network you trust, or carry the
    /// port over a VPN or SSH.
    #[arg(long, help_heading = HEADING, value_name = "ENDPOINT", requires = "export",
          value_parser = endpoint)]
    pub export_listen: Vec<String>,
    /// With --export: a Zenoh endpoint the exporter connects to (the other host's
    /// `import --listen`, or a Zenoh router), e.g. tcp/192.168.1.20:7447 (repeat for
    /// more); a broken link is connected again, every second at most.
    #[arg(long, help_heading = HEADING, value_name = "ENDPOINT", requires = "export",
          value_parser = endpoint)]
    pub export_connect: Vec<String>,
    /// With --export: the pipeline's name on the network, the keys' airglyph/DOMAIN/…
    /// (the importer's --domain must match; default airglyph).
    #[arg(long, help_heading = HEADING, value_name = "DOMAIN", requires = "export",
          value_parser = domain)]
    pub export_domain: Option<String>,
}

/// A Zenoh endpoint the exporter can use: `tcp/HOST:PORT`, with Zenoh's own `?…` or
/// `#…` settings after it. Checked here so that a typo is refused at the command line
/// rather than by an exporter that dies at each start until it is given up.
fn endpoint(s: &str) -> Result<String, String> {
    let Some(rest) = s.strip_prefix("tcp/") else {
        return Err(
            "expected tcp/HOST:PORT (airglyph-zenoh is built with Zenoh's TCP transport only)"
                .into(),
        );
    };
    let address = rest.split(['?', '#']).next().unwrap_or_default();
    match address.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && port.parse::<u16>().is_ok() => Ok(s.into()),
        _ => Err(format!(
            "{address:?} is not HOST:PORT (e.g. tcp/0.0.0.0:7447)"
        )),
    }
}

/// A domain that makes one chunk of a Zenoh key: not empty, none of Zenoh's wildcards
/// or separators.
fn domain(s: &str) -> Result<String, String> {
    if s.is_empty() || s.contains(['/', '*', '$', '?', '#']) {
        return Err("one word of a Zenoh key: not empty, without / * $ ? #".into());
    }
    Ok(s.into())
}

/// Where to look for the exporter's executable.
#[derive(Debug, Clone)]
pub struct Lookup {
    /// The folder of the running `airglyph`, looked in first.
    pub beside: Option<PathBuf>,
    /// A PATH value, looked in next.
    pub path: Option<OsString>,
}

impl Lookup {
    /// This process's: beside its own executable, then its PATH.
    pub fn here() -> Self {
        Self {
            beside: std::env::current_exe()
                .ok()
                .and_then(|e| e.parent().map(Path::to_path_buf)),
            path: std::env::var_os("PATH"),
        }
    }

    /// The first executable file named `name`, beside then on PATH.
    fn find(&self, name: &str) -> Option<PathBuf> {
        let on_path = self.path.as_deref().map(std::env::split_paths);
        self.beside
            .iter()
            .cloned()
            .chain(on_path.into_iter().flatten())
            // An empty or relative PATH entry names the working directory (or one below
            // it), which is no place to pick up a program from.
            .filter(|dir| dir.is_absolute())
            .map(|dir| dir.join(name))
            .find(|p| is_executable(p))
    }
}

fn is_executable(p: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
}

impl ExportArgs {
    /// The exporter to start beside the stages, if one is asked for; an error, before
    /// anything starts, when it cannot be found or has nowhere to send.
    pub fn companion(&self, lookup: &Lookup) -> anyhow::Result<Option<CompanionPlan>> {
        let Some(Export::Zenoh) = self.export else {
            return Ok(None);
        };
        if self.export_listen.is_empty() && self.export_connect.is_empty() {
            bail!(
                "--export zenoh: give --export-listen tcp/0.0.0.0:7447 (the other host \
                 connects here) or --export-connect tcp/HOST:7447 (this device connects there)"
            );
        }
        let Some(program) = lookup.find(PROGRAM) else {
            let beside = lookup
                .beside
                .as_ref()
                .map_or("this executable".into(), |d| d.display().to_string());
            bail!(
                "--export zenoh needs the {PROGRAM} executable, which is neither beside \
                 airglyph (in {beside}) nor on PATH; build it with `cargo build --release \
                 -p {PROGRAM}` (not built by default: Zenoh is heavy to build) and put it \
                 beside airglyph or on PATH"
            );
        };
        let mut args: Vec<String> = vec!["export".into()];
        for e in &self.export_listen {
            args.extend(["--listen".into(), e.clone()]);
        }
        for e in &self.export_connect {
            args.extend(["--connect".into(), e.clone()]);
        }
        if let Some(domain) = &self.export_domain {
            args.extend(["--domain".into(), domain.clone()]);
        }
        let by_hand = shell_words(&program, &args);
        Ok(Some(CompanionPlan {
            name: "zenoh-export".into(),
            program,
            args: args.into_iter().map(OsString::from).collect(),
            by_hand,
        }))
    }
}

/// `program args…` as a shell would take it back, for "run it alone" messages.
fn shell_words(program: &Path, args: &[String]) -> String {
    let program = program.to_string_lossy();
    let words = std::iter::once(program.as_ref()).chain(args.iter().map(String::as_str));
    // Quoting fails only on a NUL byte, which no argument of a command line carries.
    shlex::try_join(words).unwrap_or_else(|_| format!("{program} {}", args.join(" ")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    fn args(line: &[&str]) -> Result<ExportArgs, clap::Error> {
        #[derive(clap::Parser)]
        struct Run {
            #[command(flatten)]
            export: ExportArgs,
        }
        let argv = std::iter::once("run").chain(line.iter().copied());
        <Run as clap::Parser>::try_parse_from(argv).map(|r| r.export)
    }

    /// A folder holding an `airglyph-zenoh` with the given mode, and the lookup that
    /// searches only that folder (as PATH) and `beside`.
    fn program_in(dir: &Path, mode: u32) -> PathBuf {
        let p = dir.join(PROGRAM);
        std::fs::write(&p, "#!/bin/sh\n").unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(mode)).unwrap();
        p
    }

    fn lookup(beside: &Path, path: &[&Path]) -> Lookup {
        Lookup {
            beside: Some(beside.to_path_buf()),
            path: Some(std::env::join_paths(path).unwrap()),
        }
    }

    #[test]
    fn a_missing_exporter_is_refused_naming_it_and_how_to_build_it() {
        let (beside, on_path) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        // Not executable: as good as missing.
        program_in(on_path.path(), 0o644);
        let line = ["--export", "zenoh", "--export-listen", "tcp/0.0.0.0:7447"];
        let err = args(&line)
            .unwrap()
            .companion(&lookup(beside.path(), &[on_path.path()]))
            .unwrap_err()
            .to_string();
        assert!(err.contains("needs the airglyph-zenoh executable"), "{err}");
        assert!(err.contains(&beside.path().display().to_string()), "{err}");
        assert!(
            err.contains("cargo build --release -p airglyph-zenoh"),
            "{err}"
        );
    }

    #[test]
    fn the_exporter_beside_airglyph_comes_before_the_one_on_path_and_gets_the_options() {
        let (beside, on_path) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let theirs = program_in(on_path.path(), 0o755);
        let e = args(&[
            "--export",
            "zenoh",
            "--export-listen",
            "tcp/0.0.0.0:7447",
            "--export-connect",
            "tcp/[::1]:7448",
            "--export-domain",
            "lab2",
        ])
        .unwrap();
        let found = |l: &Lookup| e.companion(l).unwrap().unwrap();
        assert_eq!(
            found(&lookup(beside.path(), &[on_path.path()])).program,
            theirs
        );
        let ours = program_in(beside.path(), 0o755);
        let plan = found(&lookup(beside.path(), &[on_path.path()]));
        assert_eq!(plan.program, ours);
        assert_eq!(
            plan.args,
            [
                "export",
                "--listen",
                "tcp/0.0.0.0:7447",
                "--connect",
                "tcp/[::1]:7448",
                "--domain",
                "lab2"
            ]
        );
        assert_eq!(
            plan.by_hand,
            format!(
                "{} export --listen tcp/0.0.0.0:7447 --connect 'tcp/[::1]:7448' --domain lab2",
                ours.display()
            )
        );
    }

    #[test]
    fn export_options_are_checked_at_the_command_line() {
        assert!(args(&[])
            .unwrap()
            .companion(&Lookup::here())
            .unwrap()
            .is_none());
        let err = |line: &[&str]| args(line).unwrap_err().to_string();
        assert!(err(&["--export", "iox2"]).contains("possible values: zenoh"));
        assert!(err(&["--export-listen", "tcp/0.0.0.0:7447"]).contains("--export <TO>"));
        assert!(
            err(&["--export", "zenoh", "--export-listen", "udp/0.0.0.0:7447"])
                .contains("TCP transport only")
        );
        assert!(
            err(&["--export", "zenoh", "--export-connect", "tcp/device"])
                .contains("is not HOST:PORT")
        );
        assert!(err(&["--export", "zenoh", "--export-connect", "tcp/:7447"])
            .contains("is not HOST:PORT"));
        assert!(err(&["--export", "zenoh", "--export-domain", "a/b"]).contains("one word"));
        let nowhere = args(&["--export", "zenoh"])
            .unwrap()
            .companion(&Lookup::here())
            .unwrap_err()
            .to_string();
        assert!(nowhere.contains("give --export-listen"), "{nowhere}");
        assert!(args(&[
            "--export",
            "zenoh",
            "--export-listen",
            "tcp/0.0.0.0:7447#iface=eth0"
        ])
        .is_ok());
    }
}
