//! What the pose examples share.

use airglyph_pose::PoseConfig;

/// Applies every `set:FIELD=VALUE` argument to `cfg`: any PoseConfig field, VALUE as
/// JSON, a dotted FIELD reaching into nested settings (`set:register.lengths.collar_gain=0.1`,
/// `set:geodesic_reach_ratio=[1.3,1.2]`). An unknown field is refused rather than
/// silently ignored.
pub fn apply_sets(cfg: &mut PoseConfig, args: &[String]) {
    for a in args {
        let Some((k, v)) = a.strip_prefix("set:").and_then(|kv| kv.split_once('=')) else {
            continue;
        };
        let mut j = serde_json::to_value(&*cfg).expect("a PoseConfig as JSON");
        let slot = j
            .pointer_mut(&format!("/{}", k.replace('.', "/")))
            .unwrap_or_else(|| panic!("no PoseConfig field {k}"));
        *slot = serde_json::from_str(v).expect("a JSON value");
        *cfg = serde_json::from_value(j).expect("a PoseConfig field");
    }
}
