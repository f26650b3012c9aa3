//! Options from JavaScript objects, read through the core's own schema:
//! [`MatchOptions`] and [`SceneOptions`] deserialize themselves (serde,
//! camelCase), so a key the core does not know is refused here with the
//! list of those it does, and a new option needs no change in this file.
//!
//! A JS value is checked before serde sees it: a number may be NaN or
//! fractional, and serde's own messages name neither the key nor the
//! JavaScript type. Keys and values are the caller's text: messages show
//! them escaped.

use js_sys::{Array, Object, Reflect};
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::{Map, Number, Value};
use wasm_bindgen::prelude::*;

use crate::error::{FileText, Format};
use crate::options::MatchOptions;
use crate::repeats::Placement;
use crate::scene::SceneOptions;

#[wasm_bindgen]
extern "C" {
    // Catching: an exception (a Proxy's trap) thrown through the binding's
    // frames would leave its handle borrowed for good.
    #[wasm_bindgen(catch, js_namespace = Object, js_name = keys)]
    fn object_keys(object: &Object) -> Result<Array, JsValue>;
    #[wasm_bindgen(catch, js_namespace = Array, js_name = isArray)]
    fn is_array(value: &JsValue) -> Result<bool, JsValue>;
}

/// Keys the binding reads besides a scene's [`SceneOptions`]: the format.
pub const SCENE_EXTRA_KEYS: [&str; 1] = ["format"];
/// Keys the binding reads besides [`MatchOptions`]: a resolution to
/// voxelize the scene at again, kept for later calls.
pub const MATCH_EXTRA_KEYS: [&str; 1] = ["resolution"];

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

/// `Scene.fromBytes` options: the format and the core's scene options.
pub struct SceneSettings {
    pub format: Option<Format>,
    pub options: SceneOptions,
}

impl SceneSettings {
    /// Reads a plain object (`undefined` or `null` mean the defaults).
    pub fn from_js(value: &JsValue) -> Result<SceneSettings, JsError> {
        let mut map = plain_object("scene", value)?;
        check_keys("scene", &map, &SceneOptions::DEFAULT, &SCENE_EXTRA_KEYS)?;
        let format = format_option(map.remove("format"))?;
        // The memory budget is the caller's to set, once the mesh is parsed
        // and its size known.
        Ok(SceneSettings {
            format,
            options: schema("scene", map)?,
        })
    }
}

/// `findRepeats` options: the format, and whether to write the scene as
/// an instanced glTF, placing copies by nodes or by GPU instancing.
pub struct RepeatsSettings {
    pub format: Option<Format>,
    pub instanced: Option<Placement>,
}

impl RepeatsSettings {
    /// Reads a plain object (`undefined` or `null` mean the defaults).
    pub fn from_js(value: &JsValue) -> Result<RepeatsSettings, JsError> {
        let mut map = plain_object("repeats", value)?;
        if let Some(key) = map
            .keys()
            .find(|k| !["format", "instanced"].contains(&k.as_str()))
        {
            return Err(JsError::new(&format!(
                "unknown repeats option '{}'; the options are format and instanced",
                FileText::new(key)
            )));
        }
        let instanced = match map.remove("instanced") {
            None | Some(Value::Null) => None,
            Some(Value::String(s)) if s == "nodes" => Some(Placement::Nodes),
            Some(Value::String(s)) if s == "gpu-instancing" => Some(Placement::GpuInstancing),
            Some(other) => {
                return Err(JsError::new(&format!(
                    "invalid option instanced: '{}' is not 'nodes' or 'gpu-instancing'",
                    FileText::new(&other.to_string())
                )));
            }
        };
        Ok(RepeatsSettings {
            format: format_option(map.remove("format"))?,
            instanced,
        })
    }
}

/// `Template.fromBytes` options (`what`: "template"): the format only.
pub fn format_only(what: &str, value: &JsValue) -> Result<Option<Format>, JsError> {
    let mut map = plain_object(what, value)?;
    if let Some(key) = map.keys().find(|k| k.as_str() != "format") {
        return Err(JsError::new(&format!(
            "unknown {what} option '{}'; the only option is format",
            FileText::new(key)
        )));
    }
    format_option(map.remove("format"))
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
        let mut map = plain_object("match", value)?;
        check_keys("match", &map, &MatchOptions::DEFAULT, &MATCH_EXTRA_KEYS)?;
        let resolution = match map.remove("resolution") {
            None => None,
            Some(value) => Some(field::<u32>("resolution", value)?),
        };
        Ok(MatchSettings {
            options: schema("match", map)?,
            resolution,
        })
    }
}

/// The defaults of every option, `{ scene, match }`, as the CLI's flags and
/// the viewer's fields are built from them.
pub fn defaults() -> Result<JsValue, JsError> {
    let json = serde_json::json!({
        "scene": SceneOptions::DEFAULT,
        "match": MatchOptions::DEFAULT,
    });
    js_sys::JSON::parse(&json.to_string()).map_err(|_| JsError::new("cannot build the defaults"))
}

/// A format name (an extension: glb, gltf, obj, ply, stl).
fn format_option(value: Option<Value>) -> Result<Option<Format>, JsError> {
    let name = match value {
        None => return Ok(None),
        Some(Value::String(name)) if name.is_empty() => return Ok(None),
        Some(Value::String(name)) => name,
        Some(_) => return Err(JsError::new("invalid option format: expected a string")),
    };
    Format::from_extension(name.trim_start_matches('.'))
        .map(Some)
        .ok_or_else(|| {
            JsError::new(&format!(
                "invalid option format: '{}' is not one of glb, gltf, obj, ply, stl",
                FileText::new(&name)
            ))
        })
}

/// The keys a schema type serializes to: its settable options.
fn schema_keys(defaults: &impl Serialize) -> Vec<String> {
    match serde_json::to_value(defaults) {
        Ok(Value::Object(map)) => map.into_iter().map(|(k, _)| k).collect(),
        _ => Vec::new(),
    }
}

/// Refuses a key that neither the schema nor the binding reads, naming all
/// that are (serde would refuse it too, without the binding's extra keys).
fn check_keys(
    what: &str,
    map: &Map<String, Value>,
    defaults: &impl Serialize,
    extra: &[&str],
) -> Result<(), JsError> {
    let mut known = schema_keys(defaults);
    known.extend(extra.iter().map(|k| k.to_string()));
    match map.keys().find(|k| !known.contains(k)) {
        None => Ok(()),
        Some(key) => Err(JsError::new(&format!(
            "unknown {what} option '{}'; the options are {}",
            FileText::new(key),
            known.join(", ")
        ))),
    }
}

/// Deserializes a schema type from the object's remaining keys; a value
/// serde refuses is reported with its key.
fn schema<T: DeserializeOwned>(what: &str, map: Map<String, Value>) -> Result<T, JsError> {
    // One key at a time first (the others take their defaults), so that an
    // error names the key it is about.
    for (key, value) in &map {
        let single = Map::from_iter([(key.clone(), value.clone())]);
        if let Err(e) = serde_json::from_value::<T>(Value::Object(single)) {
            return Err(invalid(key, &e));
        }
    }
    serde_json::from_value(Value::Object(map))
        .map_err(|e| JsError::new(&format!("invalid {what} options: {}", plain(&e))))
}

fn field<T: DeserializeOwned>(key: &str, value: Value) -> Result<T, JsError> {
    serde_json::from_value(value).map_err(|e| invalid(key, &e))
}

fn invalid(key: &str, error: &serde_json::Error) -> JsError {
    JsError::new(&format!(
        "invalid option {}: {}",
        FileText::new(key),
        plain(error)
    ))
}

/// An option's name in the core's words ("volume threshold") as
/// JavaScript spells it (`volumeThreshold`).
pub fn js_name(words: &str) -> String {
    let mut name = String::with_capacity(words.len());
    for (i, word) in words.split(' ').enumerate() {
        let mut chars = word.chars();
        match chars.next() {
            Some(first) if i > 0 => name.extend(first.to_uppercase().chain(chars)),
            Some(first) => name.extend(std::iter::once(first).chain(chars)),
            None => {}
        }
    }
    name
}

/// serde's message in JavaScript's words (it may quote the value).
fn plain(error: &serde_json::Error) -> String {
    let text = error
        .to_string()
        .replace("expected f64", "expected a number")
        .replace("expected u32", "expected a whole number")
        .replace("expected usize", "expected a whole number");
    FileText::new(&text).to_string()
}

/// The own enumerable properties of a plain object as JSON values;
/// `undefined` properties are left out (they mean "the default").
fn plain_object(what: &str, value: &JsValue) -> Result<Map<String, Value>, JsError> {
    let mut map = Map::new();
    if value.is_undefined() || value.is_null() {
        return Ok(map);
    }
    let unreadable = |_| JsError::new(&format!("cannot read the {what} options"));
    let Some(object) = value.dyn_ref::<Object>() else {
        return Err(JsError::new(&format!("{what} options must be an object")));
    };
    if is_array(value).map_err(unreadable)? {
        return Err(JsError::new(&format!("{what} options must be an object")));
    }
    for key in object_keys(object).map_err(unreadable)?.iter() {
        let key = key.as_string().unwrap_or_default();
        let value = Reflect::get(object, &JsValue::from_str(&key)).map_err(|_| {
            JsError::new(&format!(
                "cannot read {what} option {}",
                FileText::new(&key)
            ))
        })?;
        if value.is_undefined() {
            continue;
        }
        let json = if let Some(n) = value.as_f64() {
            Value::Number(number(&key, n)?)
        } else if let Some(s) = value.as_string() {
            Value::String(s)
        } else if let Some(b) = value.as_bool() {
            Value::Bool(b)
        } else {
            return Err(JsError::new(&format!(
                "invalid option {}: expected a number or a string",
                FileText::new(&key)
            )));
        };
        map.insert(key, json);
    }
    Ok(map)
}

/// A JS number as JSON: whole numbers as integers, so that integer options
/// accept them; NaN and infinities are refused here, naming the key.
fn number(key: &str, n: f64) -> Result<Number, JsError> {
    const EXACT: f64 = 9_007_199_254_740_992.0; // 2^53
    if n.fract() == 0.0 && n.abs() <= EXACT {
        Ok(if n < 0.0 {
            Number::from(n as i64)
        } else {
            Number::from(n as u64)
        })
    } else {
        Number::from_f64(n).ok_or_else(|| {
            JsError::new(&format!(
                "invalid option {}: expected a finite number, got {n}",
                FileText::new(key)
            ))
        })
    }
}
