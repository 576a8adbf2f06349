//! The headless browser the page tests rely on: it draws WebGL and it reports console errors,
//! so a page test that sees no error and a drawn canvas means what it says.

#![allow(
    clippy::print_stderr,
    reason = "a test says what it measured and what it skipped"
)]

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

/// The Python that runs `rapidchecker` (`.ci/run` installs it and names it in
/// `TEACHCAM_RAPIDCHECKER_PYTHON`), else `python3` when it has the package.
fn rapidchecker_python() -> Option<std::path::PathBuf> {
    std::env::var_os("TEACHCAM_RAPIDCHECKER_PYTHON")
        .map(std::path::PathBuf::from)
        .into_iter()
        .chain([std::path::PathBuf::from("python3")])
        .find(|python| {
            std::process::Command::new(python)
                .args(["-m", "rapidchecker", "--help"])
                .output()
                .is_ok_and(|o| o.status.success())
        })
}

/// Fails the check with a message unless the condition holds (the browser is closed either
/// way: a panic inside the checks would leave Chromium running).
macro_rules! ensure {
    ($condition:expr, $($message:tt)+) => {
        if !$condition {
            return Err(format!($($message)+));
        }
    };
}

/// The studio on the simulator, in headless Chromium: no console error, three cameras drawn
/// at ≥ 20 frames per second, the tool drawn in the 3-D canvas (its colour read back where it
/// projects), the arm on the checked path, the review curve changing with the cut-off, and a
/// RAPID download that rapidchecker parses.
#[tokio::test(flavor = "multi_thread")]
async fn the_studio_shows_the_live_rig_and_exports_rapid() {
    let test = "the_studio_shows_the_live_rig_and_exports_rapid";
    let Some(browser) = Browser::open(test).await else {
        return;
    };
    let out = tempfile::tempdir().expect("a temporary folder");
    let served = support::studio::serve(support::studio::sim_config(out.path(), 60)).await;
    let outcome = studio_checks(test, &browser, &served).await;
    let errors = browser.errors().await;
    browser.close().await;
    served.studio.finish();
    if let Err(message) = outcome {
        panic!("{test}: {message}");
    }
    assert!(errors.is_empty(), "console errors: {errors:?}");
}

async fn studio_checks(
    test: &str,
    browser: &Browser,
    served: &support::studio::Served,
) -> Result<(), String> {
    browser
        .client
        .goto(&served.url())
        .await
        .map_err(|e| format!("the browser opens the studio: {e}"))?;
    let studio = "window.teachcamStudio";
    ensure!(
        browser
            .wait_for(
                &format!("return {studio} !== undefined && {studio}.framesDrawn > 5"),
                Duration::from_secs(30)
            )
            .await,
        "live frames are drawn: {}",
        browser.eval(&format!("return {studio}")).await
    );
    // The live view's rate over three seconds, counted by the page itself.
    let drawn = |v: serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let before = drawn(browser.eval(&format!("return {studio}.framesDrawn")).await);
    let started = std::time::Instant::now();
    tokio::time::sleep(Duration::from_secs(3)).await;
    let after = drawn(browser.eval(&format!("return {studio}.framesDrawn")).await);
    let fps = (after - before) / started.elapsed().as_secs_f64();
    let timing = browser
        .eval(&format!(
            "return {{pipeline_fps: {studio}.status && {studio}.status.fps, renders: {studio}.sceneRenders, frame_ms: {studio}.frameMs, render_ms: {studio}.renderMs}}"
        ))
        .await;
    eprintln!("{test}: live view {fps:.1} frames per second with 3 cameras ({timing})");
    ensure!(
        fps.total_cmp(&20.0).is_ge(),
        "live view at {fps:.1} fps, expected >= 20 ({timing})"
    );
    let canvases = browser
        .eval("return document.querySelectorAll('#cameras canvas').length")
        .await;
    ensure!(canvases == 3, "one canvas per camera, found {canvases}");
    let blobs = browser
        .eval("return Array.from(document.querySelectorAll('#cameras .camera')).map(c => Number(c.dataset.blobs))")
        .await;
    ensure!(
        blobs == serde_json::json!([4, 4, 4]),
        "each camera sees the tool's 4 markers: {blobs}"
    );
    ensure!(
        browser
            .wait_for(
                &format!("return {studio}.toolVisible && {studio}.toolPixelSeen"),
                Duration::from_secs(10)
            )
            .await,
        "the 3-D canvas shows the tool: {}",
        browser.eval(&format!("return {studio}")).await
    );
    // Robot: check, take the suggested work object, check again: the arm follows the path.
    browser
        .eval("document.querySelector('nav button[data-tab=robot]').click(); document.getElementById('robot-check').click(); return true")
        .await;
    ensure!(
        browser
            .wait_for(
                &format!("return {studio}.robot !== null && !document.getElementById('use-suggestion').disabled"),
                Duration::from_secs(20)
            )
            .await,
        "the check suggests a work object: {}",
        browser.eval("return document.getElementById('robot-summary').textContent").await
    );
    browser
        .eval("document.getElementById('use-suggestion').click(); return true")
        .await;
    ensure!(
        browser
            .wait_for(
                &format!("return {studio}.robot.passes === true && document.getElementById('export-rapid').hasAttribute('href')"),
                Duration::from_secs(20)
            )
            .await,
        "the suggested work object passes: {}",
        browser.eval("return document.getElementById('robot-summary').textContent").await
    );
    let frames = browser
        .eval(&format!("return {studio}.armFrames.length"))
        .await;
    ensure!(
        frames.as_u64().is_some_and(|n| n > 10),
        "the arm has a joint path: {frames}"
    );
    let rapid = browser
        .eval("return fetch(document.getElementById('export-rapid').href).then(r => r.text())")
        .await;
    let rapid = rapid.as_str().unwrap_or_default().to_string();
    ensure!(
        rapid.starts_with("MODULE teachcam_studio"),
        "a RAPID module: {}",
        &rapid[..rapid.len().min(200)]
    );
    match rapidchecker_python() {
        Some(python) => {
            let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
            let path = dir.path().join("teachcam_studio.mod");
            std::fs::write(&path, &rapid).map_err(|e| e.to_string())?;
            let checked = std::process::Command::new(python)
                .args(["-m", "rapidchecker"])
                .arg(&path)
                .output()
                .map_err(|e| format!("rapidchecker runs: {e}"))?;
            ensure!(
                checked.status.success(),
                "rapidchecker refuses the download: {}{}",
                String::from_utf8_lossy(&checked.stdout),
                String::from_utf8_lossy(&checked.stderr)
            );
        }
        None => {
            ensure!(
                std::env::var("CI").as_deref() != Ok("true"),
                "rapidchecker is not installed (.ci/run installs it)"
            );
            eprintln!("{test}: RAPID not parsed: rapidchecker not installed");
        }
    }
    Ok(())
}
