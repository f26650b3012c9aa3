//! The JavaScript binding under wasm-bindgen-test, in Node and in headless
//! Chromium (`scripts/test-wasm.sh` runs both): a shared scene's bytes give
//! the same instances as the native command on the same files, and bad
//! input is an error that leaves the module usable.
//!
//! The native result is written by `scripts/test-wasm.sh` before this test
//! is built (a wasm test cannot run the native binary).

#![cfg(all(target_arch = "wasm32", target_os = "unknown"))]

use fast_reject::wasm::{SceneHandle, TemplateHandle};
use js_sys::{Array, Function, Object, Reflect};
use wasm_bindgen::prelude::*;
use wasm_bindgen_test::*;

const SCENE: &[u8] = include_bytes!("../../shared/scenes/zoo-bunny/scene.glb");
const TEMPLATE: &[u8] = include_bytes!("../../shared/scenes/zoo-bunny/template.glb");
const NATIVE_REPORT: &str = include_str!("../target-wasm/native/zoo-bunny.json");

fn get(value: &JsValue, key: &str) -> JsValue {
    Reflect::get(value, &JsValue::from_str(key)).unwrap()
}

fn number(value: &JsValue, key: &str) -> f64 {
    get(value, key).as_f64().unwrap()
}

/// The message of a JS error returned by the binding.
/// A JS value from JSON text.
fn js(json: &str) -> JsValue {
    js_sys::JSON::parse(json).unwrap()
}

fn message(error: JsError) -> String {
    let value: JsValue = error.into();
    assert!(
        value.is_instance_of::<js_sys::Error>(),
        "not an Error: {value:?}"
    );
    String::from(value.unchecked_into::<js_sys::Error>().message())
}

#[wasm_bindgen_test]
fn zoo_bunny_matches_the_native_run() {
    let native: serde_json::Value = serde_json::from_str(NATIVE_REPORT).unwrap();
    let expected = native["instances"].as_array().unwrap();
    let mut scene = SceneHandle::from_bytes(SCENE, JsValue::UNDEFINED, None).unwrap();
    let template = TemplateHandle::from_bytes(TEMPLATE, js(r#"{"format": "glb"}"#)).unwrap();
    let layers = Array::new();
    let record = {
        let layers = layers.clone();
        Closure::<dyn FnMut(JsValue)>::new(move |stats: JsValue| {
            layers.push(&stats);
        })
    };
    let callback: &Function = record.as_ref().unchecked_ref();
    let report = scene
        .run_match(&template, JsValue::UNDEFINED, Some(callback.clone()), None)
        .unwrap();

    let instances: Array = get(&report, "instances").unchecked_into();
    assert_eq!(instances.length() as usize, expected.len());
    assert!(!expected.is_empty());
    let voxel = number(&get(&report, "grid"), "voxel_size");
    let positions: js_sys::Float64Array = get(&report, "instancePositions").unchecked_into();
    for (i, want) in expected.iter().enumerate() {
        let got = instances.get(i as u32);
        let got_position: Array = get(&got, "position").unchecked_into();
        for axis in 0..3 {
            let w = want["position"][axis].as_f64().unwrap();
            let g = got_position.get(axis as u32).as_f64().unwrap();
            // Same code, same inputs; libm may differ from glibc by an ulp.
            assert!(
                (w - g).abs() < 1e-3 * voxel,
                "instance {i} axis {axis}: {g} vs native {w}"
            );
            assert_eq!(positions.get_index(3 * i as u32 + axis as u32), g);
        }
        assert_eq!(
            number(&got, "support"),
            want["support"].as_f64().unwrap(),
            "instance {i} support"
        );
    }
    // One callback per cascade layer of every part searched; the report
    // sums them per stage and layer.
    let stages: Array = get(&report, "stages").unchecked_into();
    assert!(layers.length() >= stages.length());
    assert_eq!(
        stages.length() as usize,
        native["stages"].as_array().unwrap().len()
    );
    for i in 0..stages.length() {
        let stage = stages.get(i);
        let key = |s: &JsValue| (get(s, "descriptor").as_string(), number(s, "layer"));
        let summed: f64 = layers
            .iter()
            .filter(|l| key(l) == key(&stage))
            .map(|l| number(&l, "survivors"))
            .sum();
        assert_eq!(summed, number(&stage, "survivors"));
    }
    assert!(number(&get(&report, "timings_ms"), "total") > 0.0);
}

#[wasm_bindgen_test]
fn progress_callback_cancels_with_false_or_a_throw() {
    let mut scene = SceneHandle::from_bytes(SCENE, js(r#"{"resolution": 128}"#), None).unwrap();
    let template = TemplateHandle::from_bytes(TEMPLATE, JsValue::UNDEFINED).unwrap();
    let stop = Function::new_no_args("return false;");
    let error = message(
        scene
            .run_match(&template, JsValue::UNDEFINED, Some(stop), None)
            .unwrap_err(),
    );
    assert!(error.contains("cancelled"), "{error}");
    let throw = Function::new_no_args("throw new Error('user pressed stop');");
    let error = message(
        scene
            .run_match(&template, JsValue::UNDEFINED, Some(throw), None)
            .unwrap_err(),
    );
    assert!(error.contains("user pressed stop"), "{error}");
    // The handle still works.
    let report = scene
        .run_match(&template, JsValue::UNDEFINED, None, None)
        .unwrap();
    assert!(get(&report, "instances").is_instance_of::<Array>());
}

#[wasm_bindgen_test]
fn bad_input_is_an_error_and_the_module_stays_usable() {
    let garbage = [0xde, 0xad, 0xbe, 0xef, 1, 2, 3];
    let e = message(SceneHandle::from_bytes(&garbage, JsValue::UNDEFINED, None).unwrap_err());
    assert!(e.contains("unrecognized mesh data"), "{e}");
    let e = message(SceneHandle::from_bytes(&[], JsValue::UNDEFINED, None).unwrap_err());
    assert!(e.contains("empty"), "{e}");
    let e =
        message(SceneHandle::from_bytes(b"glTF\x02\0\0\0", JsValue::UNDEFINED, None).unwrap_err());
    assert!(e.contains("glTF"), "{e}");
    let e = message(SceneHandle::from_bytes(SCENE, js(r#"{"format": "dwg"}"#), None).unwrap_err());
    assert!(e.contains("format"), "{e}");
    let e = message(TemplateHandle::from_selection(f64::NAN, 0.0, 0.0, 1.0).unwrap_err());
    assert!(e.contains("finite"), "{e}");
    // A grid beyond wasm memory is refused before anything is allocated.
    let e =
        message(SceneHandle::from_bytes(SCENE, js(r#"{"resolution": 16384}"#), None).unwrap_err());
    assert!(e.contains("lower the resolution"), "{e}");
    let nan = Object::new();
    Reflect::set(&nan, &"resolution".into(), &f64::NAN.into()).unwrap();
    let e = message(SceneHandle::from_bytes(SCENE, nan.into(), None).unwrap_err());
    assert!(e.contains("resolution") && e.contains("finite"), "{e}");
    // Scene and template options are checked as strictly as match options.
    let e = message(SceneHandle::from_bytes(SCENE, js(r#"{"resolutoin": 64}"#), None).unwrap_err());
    assert!(e.contains("unknown scene option 'resolutoin'"), "{e}");
    let e = message(TemplateHandle::from_bytes(TEMPLATE, js(r#"{"resolution": 64}"#)).unwrap_err());
    assert!(e.contains("unknown template option 'resolution'"), "{e}");

    let mut scene = SceneHandle::from_bytes(SCENE, js(r#"{"resolution": 128}"#), None).unwrap();
    let template = TemplateHandle::from_bytes(TEMPLATE, JsValue::UNDEFINED).unwrap();
    let options = js;
    for (bad, expect) in [
        (r#"{"descriptor": "sift"}"#, "descriptor"),
        (r#"{"resolutoin": 256}"#, "unknown match option"),
        (
            r#"{"layers": 0.5}"#,
            "invalid option layers: invalid type: floating point `0.5`, expected a whole number",
        ),
        // Named as JavaScript spells them, not in the core's words.
        (
            r#"{"groupRadius": -1}"#,
            "invalid option groupRadius: must be",
        ),
        (
            r#"{"verifyThreshold": 2}"#,
            "invalid option verifyThreshold: must",
        ),
        (r#"{"volumeThreshold": "high"}"#, "expected a number"),
        (r#"{"resolution": 16384}"#, "lower the resolution"),
        ("42", "must be an object"),
        ("[1]", "must be an object"),
    ] {
        let e = message(
            scene
                .run_match(&template, options(bad), None, None)
                .unwrap_err(),
        );
        assert!(e.contains(expect), "{bad}: {e}");
    }
    // A selection that misses the scene is the core's error.
    let far = TemplateHandle::from_selection(1e6, 1e6, 1e6, 1.0).unwrap();
    let e = message(
        scene
            .run_match(&far, JsValue::UNDEFINED, None, None)
            .unwrap_err(),
    );
    assert!(e.contains("touches no surface"), "{e}");
    // After all of that, the same handles still search (and kept the old grid).
    assert_eq!(scene.resolution(), 128);
    let report = scene
        .run_match(&template, Object::new().into(), None, None)
        .unwrap();
    assert!(get(&report, "instances").is_instance_of::<Array>());
}

#[wasm_bindgen_test]
fn the_option_defaults_are_accepted_as_options() {
    let defaults = fast_reject::wasm::option_defaults().unwrap();
    let scene_defaults = get(&defaults, "scene");
    let match_defaults = get(&defaults, "match");
    assert_eq!(get(&scene_defaults, "resolution").as_f64(), Some(512.0));
    assert_eq!(
        get(&match_defaults, "descriptor").as_string().as_deref(),
        Some("volume+harmonics")
    );
    assert_eq!(get(&match_defaults, "groupRadius").as_f64(), Some(1.0));
    // Set at a lower resolution (the defaults' 512 is slow here), and the
    // match defaults as they are: every key they hold is a valid option.
    Reflect::set(&scene_defaults, &"resolution".into(), &128.into()).unwrap();
    let mut scene = SceneHandle::from_bytes(SCENE, scene_defaults, None).unwrap();
    let template = TemplateHandle::from_bytes(TEMPLATE, JsValue::UNDEFINED).unwrap();
    let report = scene
        .run_match(&template, match_defaults, None, None)
        .unwrap();
    assert!(get(&report, "instances").is_instance_of::<Array>());
}

#[wasm_bindgen_test]
fn options_that_throw_while_read_are_an_error_and_the_scene_stays_usable() {
    let mut scene = SceneHandle::from_bytes(SCENE, js(r#"{"resolution": 128}"#), None).unwrap();
    let template = TemplateHandle::from_bytes(TEMPLATE, JsValue::UNDEFINED).unwrap();
    // A Proxy's trap that throws, while the binding reads the options: an
    // exception through the binding's frames would leave the scene
    // borrowed for good (every later call "recursive use of an object").
    let proxy = Function::new_with_args(
        "trap",
        "return new Proxy({ groupRadius: 1 }, { [trap]() { throw new Error('no'); } });",
    );
    for trap in ["ownKeys", "getOwnPropertyDescriptor", "get"] {
        let options = proxy.call1(&JsValue::NULL, &trap.into()).unwrap();
        let e = message(scene.run_match(&template, options, None, None).unwrap_err());
        assert!(e.contains("cannot read"), "{trap}: {e}");
    }
    let revoked = Function::new_no_args(
        "const { proxy, revoke } = Proxy.revocable({}, {}); revoke(); return proxy;",
    )
    .call0(&JsValue::NULL)
    .unwrap();
    let e = message(scene.run_match(&template, revoked, None, None).unwrap_err());
    assert!(e.contains("must be an object"), "{e}");
    // The caller's key is quoted escaped, never as a control character.
    let e = message(
        scene
            .run_match(&template, js(r#"{"k\u001b[2J": 1}"#), None, None)
            .unwrap_err(),
    );
    assert!(e.contains(r"'k\u{1b}[2J'") && !e.contains('\u{1b}'), "{e}");
    let report = scene
        .run_match(&template, JsValue::UNDEFINED, None, None)
        .unwrap();
    assert!(get(&report, "instances").is_instance_of::<Array>());
}
