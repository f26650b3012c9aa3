//! The npm package's `index.d.ts` against the core's option schema: the
//! TypeScript interfaces must list exactly the keys that `MatchOptions` and
//! `SceneOptions` serialize to (plus the binding's own: a scene's format,
//! a match's resolution), with the same documented defaults, and the
//! descriptor union must name exactly the core's descriptors. Adding an
//! option to the core without the typings (or the reverse) fails here.

#![cfg(feature = "serde")]

use std::collections::BTreeMap;

use fast_reject::{DescriptorKind, MatchOptions, SceneOptions};
use serde_json::Value;

const TYPINGS: &str = include_str!("../js/src/index.d.ts");

/// The binding's keys besides the schema's (src/wasm/options.rs).
const SCENE_EXTRA: [&str; 1] = ["format"];
const MATCH_EXTRA: [&str; 1] = ["resolution"];

/// The body of `export interface NAME { ... }`.
fn interface(name: &str) -> &'static str {
    let head = format!("export interface {name} {{");
    let start = TYPINGS
        .find(&head)
        .unwrap_or_else(|| panic!("index.d.ts has no interface {name}"))
        + head.len();
    let end = start + TYPINGS[start..].find("\n}").expect("interface end");
    &TYPINGS[start..end]
}

/// Each property of an interface body with the doc comment just above it.
fn properties(body: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut doc = String::new();
    for line in body.lines().map(str::trim) {
        if line.starts_with("/**") || line.starts_with('*') {
            doc.push_str(line);
            doc.push(' ');
        } else if let Some((key, _)) = line.split_once(':') {
            out.insert(
                key.trim_end_matches('?').to_string(),
                std::mem::take(&mut doc),
            );
        }
    }
    out
}

/// The keys and default values an options type serializes to.
fn schema(defaults: &impl serde::Serialize) -> BTreeMap<String, Value> {
    match serde_json::to_value(defaults).unwrap() {
        Value::Object(map) => map.into_iter().collect(),
        other => panic!("options serialize to an object, got {other}"),
    }
}

/// The default a doc comment states: "(default 0.12)", "(default 'volume')".
fn documented_default(doc: &str) -> Option<String> {
    let start = doc.find("default ")? + "default ".len();
    let rest = &doc[start..];
    let end = rest.find(')')?;
    Some(rest[..end].trim_matches('\'').to_string())
}

fn check(interface_name: &str, defaults: BTreeMap<String, Value>, extra: &[&str]) {
    let typed = properties(interface(interface_name));
    let mut expected: Vec<String> = defaults.keys().cloned().collect();
    expected.extend(extra.iter().map(|k| k.to_string()));
    expected.sort();
    let typed_keys: Vec<String> = typed.keys().cloned().collect();
    assert_eq!(
        typed_keys, expected,
        "index.d.ts {interface_name} and the core's options disagree"
    );
    for (key, value) in &defaults {
        let doc = &typed[key];
        let stated = documented_default(doc)
            .unwrap_or_else(|| panic!("{interface_name}.{key}: no '(default ...)' in {doc:?}"));
        let agrees = match value {
            Value::Number(n) => stated.parse::<f64>().ok() == n.as_f64(),
            Value::String(s) => &stated == s,
            Value::Bool(b) => stated == b.to_string(),
            other => panic!("{key}: an option of an unexpected type {other}"),
        };
        assert!(
            agrees,
            "{interface_name}.{key}: index.d.ts says default {stated}, the core {value}"
        );
    }
}

#[test]
fn match_options_in_typescript_are_the_core_schema() {
    check("MatchOptions", schema(&MatchOptions::DEFAULT), &MATCH_EXTRA);
}

#[test]
fn scene_options_in_typescript_are_the_core_schema() {
    check("SceneOptions", schema(&SceneOptions::DEFAULT), &SCENE_EXTRA);
}

#[test]
fn the_descriptor_union_names_every_descriptor() {
    let line = TYPINGS
        .lines()
        .find(|l| l.starts_with("export type DescriptorName ="))
        .expect("index.d.ts declares DescriptorName");
    let typed: Vec<&str> = line.split('\'').skip(1).step_by(2).collect();
    let core: Vec<&str> = DescriptorKind::ALL.iter().map(|k| k.name()).collect();
    assert_eq!(typed, core);
    // And serde spells them the same way as the CLI and the reports.
    for kind in DescriptorKind::ALL {
        assert_eq!(serde_json::to_value(kind).unwrap(), kind.name());
    }
}

#[test]
fn unknown_keys_are_refused_and_the_defaults_read_back() {
    let typo = serde_json::json!({ "volumeTreshold": 0.2 });
    let error = serde_json::from_value::<MatchOptions>(typo)
        .unwrap_err()
        .to_string();
    assert!(error.contains("unknown field `volumeTreshold`"), "{error}");
    let typo = serde_json::json!({ "resolutoin": 64 });
    assert!(serde_json::from_value::<SceneOptions>(typo).is_err());
    let defaults = serde_json::to_value(MatchOptions::DEFAULT).unwrap();
    assert_eq!(
        serde_json::from_value::<MatchOptions>(defaults).unwrap(),
        MatchOptions::DEFAULT
    );
    let some = serde_json::json!({ "descriptor": "curvature", "groupRadius": 0.5 });
    let options: MatchOptions = serde_json::from_value(some).unwrap();
    assert_eq!(options.descriptor, DescriptorKind::Curvature);
    assert_eq!(options.group_radius, 0.5);
    assert_eq!(options.layers, MatchOptions::DEFAULT.layers);
}
