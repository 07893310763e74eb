//! The Zenoh session both sides open: peer to peer over TCP, to the endpoints given,
//! without multicast scouting (a device on a shared network would otherwise find, and
//! be found by, every Zenoh peer there).

use anyhow::Context;
use zenoh::Wait;

/// Where a side listens and what it connects to.
#[derive(clap::Args, Debug, Clone)]
pub struct Endpoints {
    /// Zenoh endpoints to listen on, e.g. tcp/0.0.0.0:7447 (repeat for more).
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Zenoh endpoints to connect to, e.g. tcp/192.168.1.20:7447 (repeat for more); a
    /// broken link is connected again by Zenoh, every second at most.
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// The name of this pipeline on the network: the keys are airglyph/<DOMAIN>/…, so
    /// several devices can share one network.
    #[arg(long, default_value = "airglyph")]
    pub domain: String,
}

fn json_list(items: &[String]) -> String {
    serde_json::to_string(items).expect("strings serialize")
}

/// Opens the session.
pub fn open(endpoints: &Endpoints) -> anyhow::Result<zenoh::Session> {
    anyhow::ensure!(
        !endpoints.listen.is_empty() || !endpoints.connect.is_empty(),
        "nothing to listen on or connect to: give --listen or --connect"
    );
    let mut config = zenoh::Config::default();
    let set = |config: &mut zenoh::Config, key: &str, value: &str| {
        config
            .insert_json5(key, value)
            .map_err(|e| anyhow::anyhow!("zenoh setting {key} = {value}: {e}"))
    };
    set(&mut config, "mode", "\"peer\"")?;
    set(&mut config, "scouting/multicast/enabled", "false")?;
    set(
        &mut config,
        "listen/endpoints",
        &json_list(&endpoints.listen),
    )?;
    set(
        &mut config,
        "connect/endpoints",
        &json_list(&endpoints.connect),
    )?;
    // Keep trying a peer that is not there yet or went away, for ever, without waiting
    // long between tries: a device that reboots is back within a second of its start.
    set(&mut config, "connect/timeout_ms", "-1")?;
    set(&mut config, "connect/exit_on_failure", "false")?;
    set(
        &mut config,
        "connect/retry",
        r#"{"period_init_ms": 100, "period_max_ms": 1000, "period_increase_factor": 2}"#,
    )?;
    zenoh::open(config)
        .wait()
        .map_err(|e| anyhow::anyhow!("{e}"))
        .context("cannot open the Zenoh session")
}

/// The key of one service of a domain.
pub fn key(domain: &str, service: &str) -> String {
    format!("airglyph/{domain}/{service}")
}
