//! The headless browser the page tests rely on: it draws WebGL and it reports console errors,
//! so a page test that sees no error and a drawn canvas means what it says.

mod support;

use std::time::Duration;

use support::browser::Browser;

/// A page that clears a WebGL canvas to a known colour and logs one console error.
const PAGE: &str = r#"<!doctype html><html><body><canvas id="c" width="8" height="8"></canvas>
<script>
const gl = document.getElementById("c").getContext("webgl2", {preserveDrawingBuffer: true});
let pixel = null;
if (gl) {
  gl.clearColor(1.0, 0.5, 0.0, 1.0);
  gl.clear(gl.COLOR_BUFFER_BIT);
  const out = new Uint8Array(4);
  gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, out);
  pixel = Array.from(out);
}
window.result = {webgl: !!gl, pixel};
console.error("the planted error");
</script></body></html>"#;

#[tokio::test(flavor = "multi_thread")]
async fn the_browser_draws_webgl_and_reports_console_errors() {
    let Some(browser) = Browser::open("the_browser_draws_webgl_and_reports_console_errors").await
    else {
        return;
    };
    let dir = tempfile::tempdir().expect("a temporary folder");
    let page = dir.path().join("page.html");
    std::fs::write(&page, PAGE).expect("writing the page");
    browser.open_file(&page).await;
    assert!(
        browser
            .wait_for(
                "return window.result !== undefined",
                Duration::from_secs(10)
            )
            .await,
        "the page's script ran"
    );
    let result = browser.eval("return window.result").await;
    assert_eq!(result["webgl"], true, "WebGL 2 is available: {result}");
    // 1.0, 0.5, 0.0 in 8 bits: 255, 127 or 128 (the rounding is the driver's), 0, opaque.
    let pixel: Vec<u64> = result["pixel"]
        .as_array()
        .expect("the pixel was read")
        .iter()
        .filter_map(|v| v.as_u64())
        .collect();
    assert_eq!(pixel.len(), 4, "{result}");
    assert_eq!((pixel[0], pixel[2], pixel[3]), (255, 0, 255), "{result}");
    assert!((127..=128).contains(&pixel[1]), "{result}");
    let errors = browser.errors().await;
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert!(errors[0].contains("the planted error"), "{errors:?}");
    browser.close().await;
}
