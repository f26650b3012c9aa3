//! The WebGPU path in headless Chromium (its SwiftShader adapter, with the
//! flags in webdriver.json): the binding's `matchGpu` finds what `match`
//! finds, layer for layer, on the embedded demo scene. SwiftShader is a
//! software adapter, so the test allows it and keeps the scene small.

#![cfg(all(target_arch = "wasm32", target_os = "unknown", feature = "gpu"))]

use fast_reject::wasm::{SceneHandle, TemplateHandle};
use js_sys::{Array, Reflect};
use wasm_bindgen::prelude::*;
use wasm_bindgen_test::*;

wasm_bindgen_test_configure!(run_in_browser);

const SCENE: &[u8] = include_bytes!("../assets/demo/scene.glb");
const TEMPLATE: &[u8] = include_bytes!("../assets/demo/template.glb");

fn get(value: &JsValue, key: &str) -> JsValue {
    Reflect::get(value, &JsValue::from_str(key)).unwrap()
}

fn array(value: &JsValue, key: &str) -> Array {
    get(value, key).unchecked_into()
}

/// (descriptor, layer, candidates, survivors) per reported layer.
fn layers(report: &JsValue) -> Vec<(String, f64, f64, f64)> {
    array(report, "stages")
        .iter()
        .map(|s| {
            let n = |k: &str| get(&s, k).as_f64().unwrap();
            (
                get(&s, "descriptor").as_string().unwrap(),
                n("layer"),
                n("candidates"),
                n("survivors"),
            )
        })
        .collect()
}

#[wasm_bindgen_test]
async fn webgpu_finds_what_the_cpu_finds() {
    let mut scene = SceneHandle::from_bytes(SCENE, JsValue::UNDEFINED, None).unwrap();
    let template = TemplateHandle::from_bytes(TEMPLATE, JsValue::UNDEFINED).unwrap();
    let cpu = scene
        .run_match(&template, JsValue::UNDEFINED, None, None)
        .unwrap();
    let gpu = scene
        .run_match_gpu(&template, JsValue::UNDEFINED, None, None, true)
        .await
        .unwrap();
    let info = get(&gpu, "gpu");
    assert!(
        !info.is_null(),
        "no WebGPU adapter: Chromium needs --enable-unsafe-webgpu (webdriver.json)"
    );
    assert!(
        get(&info, "fallback").is_null(),
        "{:?}",
        get(&info, "fallback")
    );
    assert!(get(&cpu, "gpu").is_null());
    assert_eq!(layers(&cpu), layers(&gpu));
    let positions = |r: &JsValue| -> Vec<Vec<f64>> {
        array(r, "instances")
            .iter()
            .map(|i| {
                array(&i, "position")
                    .iter()
                    .map(|x| x.as_f64().unwrap())
                    .collect()
            })
            .collect()
    };
    assert_eq!(positions(&cpu).len(), 3);
    assert_eq!(positions(&cpu), positions(&gpu));
    // Without leave to use a software adapter, SwiftShader is not used: the
    // CPU runs and the report says no GPU ran.
    let plain = scene
        .run_match_gpu(&template, JsValue::UNDEFINED, None, None, false)
        .await
        .unwrap();
    assert!(get(&plain, "gpu").is_null());
    assert_eq!(positions(&plain), positions(&cpu));
}
