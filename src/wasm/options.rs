//! Options from JavaScript values, checked before they reach the core: a
//! JS number can be NaN, fractional or huge, and a misspelt key would
//! otherwise be ignored silently.

use std::str::FromStr;

use js_sys::{Object, Reflect};
use wasm_bindgen::prelude::*;

use crate::error::Format;
use crate::scene::SceneOptions;
use crate::search::{DescriptorKind, MatchOptions};

/// The option names `match` accepts (the CLI's flags, in camelCase).
const MATCH_KEYS: [&str; 10] = [
    "descriptor",
    "resolution",
    "layers",
    "volumeThreshold",
    "curvatureThreshold",
    "curvatureSpacing",
    "harmonicsThreshold",
    "verifyThreshold",
    "hiddenSurface",
    "groupRadius",
];

/// Bytes the module's linear memory may grow to: the threaded build is
/// linked with `--max-memory=1073741824` (scripts/build-wasm.sh); the plain
/// one may use the whole 32-bit address space.
pub fn memory_limit_bytes() -> u64 {
    if cfg!(target_feature = "atomics") {
        1 << 30
    } else {
        4 << 30
    }
}

/// The memory budget of a scene and its searches, given that `counted`
/// of the live heap is already in the core's estimate for it: at most half
/// of what the module may grow to, and no more than is free now (other
/// scenes and templates the page holds count), keeping an eighth of the
/// module for what the estimates leave out (the input bytes copied in from
/// JavaScript, the report, the allocator's slack). A failed allocation
/// would trap the module.
pub fn memory_budget(counted: u64) -> u64 {
    let limit = memory_limit_bytes();
    let free = (limit - limit / 8).saturating_sub(super::heap::live_bytes());
    (limit / 2).min(free.saturating_add(counted))
}

/// Scene options for a resolution given from JavaScript (default 512).
pub fn scene_options(resolution: Option<f64>) -> Result<SceneOptions, JsError> {
    let mut options = SceneOptions::DEFAULT.with_memory_budget(memory_budget(0));
    if let Some(value) = resolution {
        options = options.with_resolution(whole_number("resolution", value, 8, 16384)?);
    }
    Ok(options)
}

/// A format name (an extension: glb, gltf, obj, ply, stl), or none to
/// recognize the content.
pub fn parse_format(name: Option<&str>) -> Result<Option<Format>, JsError> {
    match name {
        None | Some("") => Ok(None),
        Some(name) => Format::from_extension(name.trim_start_matches('.'))
            .map(Some)
            .ok_or_else(|| {
                JsError::new(&format!(
                    "invalid option format: '{name}' is not one of glb, gltf, obj, ply, stl"
                ))
            }),
    }
}

/// `match` options: the core's [`MatchOptions`] and a resolution to
/// voxelize the scene at, if it differs from the scene's.
pub struct MatchSettings {
    pub options: MatchOptions,
    pub resolution: Option<u32>,
}

impl MatchSettings {
    /// Reads a plain object (`undefined` or `null` mean the defaults).
    pub fn from_js(value: &JsValue) -> Result<MatchSettings, JsError> {
        let mut settings = MatchSettings {
            options: MatchOptions::DEFAULT,
            resolution: None,
        };
        if value.is_undefined() || value.is_null() {
            return Ok(settings);
        }
        let Some(object) = value.dyn_ref::<Object>() else {
            return Err(JsError::new("match options must be an object"));
        };
        for key in Object::keys(object).iter() {
            let key = key.as_string().unwrap_or_default();
            if !MATCH_KEYS.contains(&key.as_str()) {
                return Err(JsError::new(&format!(
                    "unknown match option '{key}'; the options are {}",
                    MATCH_KEYS.join(", ")
                )));
            }
        }
        let options = &mut settings.options;
        if let Some(name) = string(object, "descriptor")? {
            // Through FromStr, so that every descriptor the core knows is
            // accepted here without a change.
            options.descriptor =
                DescriptorKind::from_str(&name).map_err(|e| JsError::new(&e.to_string()))?;
        }
        if let Some(v) = number(object, "resolution")? {
            settings.resolution = Some(whole_number("resolution", v, 8, 16384)?);
        }
        if let Some(v) = number(object, "layers")? {
            options.layers = whole_number("layers", v, 1, 64)? as usize;
        }
        // The core validates the ranges of the thresholds (NaN included).
        if let Some(v) = number(object, "volumeThreshold")? {
            options.volume_threshold = v;
        }
        if let Some(v) = number(object, "harmonicsThreshold")? {
            options.harmonics_threshold = v;
        }
        if let Some(v) = number(object, "curvatureThreshold")? {
            options.curvature_threshold = v;
        }
        if let Some(v) = number(object, "curvatureSpacing")? {
            options.curvature_spacing = v;
        }
        if let Some(v) = number(object, "verifyThreshold")? {
            options.verify_threshold = v;
        }
        if let Some(v) = number(object, "hiddenSurface")? {
            options.clutter.hidden_surface = v;
        }
        if let Some(v) = number(object, "groupRadius")? {
            options.group_radius = v;
        }
        Ok(settings)
    }
}

/// The property `key`, or `None` when it is absent or undefined.
fn property(object: &Object, key: &str) -> Result<Option<JsValue>, JsError> {
    let value = Reflect::get(object, &JsValue::from_str(key))
        .map_err(|_| JsError::new(&format!("cannot read option {key}")))?;
    Ok((!value.is_undefined()).then_some(value))
}

fn number(object: &Object, key: &str) -> Result<Option<f64>, JsError> {
    match property(object, key)? {
        None => Ok(None),
        Some(value) => value
            .as_f64()
            .map(Some)
            .ok_or_else(|| JsError::new(&format!("invalid option {key}: expected a number"))),
    }
}

fn string(object: &Object, key: &str) -> Result<Option<String>, JsError> {
    match property(object, key)? {
        None => Ok(None),
        Some(value) => value
            .as_string()
            .map(Some)
            .ok_or_else(|| JsError::new(&format!("invalid option {key}: expected a string"))),
    }
}

/// `value` as an integer in `min..=max`, or an error that says so.
fn whole_number(name: &str, value: f64, min: u32, max: u32) -> Result<u32, JsError> {
    if value.fract() == 0.0 && value >= min as f64 && value <= max as f64 {
        Ok(value as u32)
    } else {
        Err(JsError::new(&format!(
            "invalid option {name}: expected a whole number in {min}..={max}, got {value}"
        )))
    }
}
