//! The headless browser the page tests rely on: it draws WebGL and it reports console errors,
//! so a page test that sees no error and a drawn canvas means what it says.

#![allow(
    clippy::print_stderr,
    reason = "a test says what it measured and what it skipped"
)]

mod support;

use std::time::Duration;

use teachcam_testdata::browser::Browser;

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

/// Saves a screenshot of the page as `NAME.png` in `TEACHCAM_SCREENSHOTS` when that is set
/// (to look at the page by hand).
async fn screenshot(browser: &Browser, name: &str) {
    let Some(dir) = std::env::var_os("TEACHCAM_SCREENSHOTS") else {
        return;
    };
    if let Ok(png) = browser.client.screenshot().await {
        let _ = std::fs::write(std::path::Path::new(&dir).join(format!("{name}.png")), png);
    }
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
    screenshot(browser, "live").await;
    // The cell framed: every camera tile above the fold, the floor's scale bar written.
    let layout = browser
        .eval("return {bottoms: Array.from(document.querySelectorAll('#cameras canvas')).map(c => c.getBoundingClientRect().bottom), height: window.innerHeight, scale: window.teachcamStudio.scaleBar, crowded: window.teachcamStudio.labelsCrowded}")
        .await;
    ensure!(
        layout["bottoms"]
            .as_array()
            .is_some_and(|b| b.len() == 3
                && b.iter().all(|v| v.as_f64().unwrap_or(f64::INFINITY)
                    <= layout["height"].as_f64().unwrap_or(0.0)))
            && layout["scale"]
                .as_str()
                .is_some_and(|s| s.ends_with("mm") || s.ends_with(" m")),
        "the camera tiles fit the window and the floor has its scale: {layout}"
    );
    // Review: the take's figures drawn at the slider's cut-off; moving the slider re-smooths
    // and the plotted smoothed curve changes.
    browser
        .eval("document.querySelector('nav button[data-tab=review]').click(); return true")
        .await;
    let drawn_at = |cutoff: &str| {
        format!(
            "return {studio}.reviewDraws > 0 && {studio}.reviewCutoffHz === {cutoff} \
             && document.querySelectorAll('#review section[data-figure=components] .uplot canvas').length > 0"
        )
    };
    ensure!(
        browser
            .wait_for(&drawn_at("6"), Duration::from_secs(20))
            .await,
        "the review draws the take at 6 Hz: {}",
        browser
            .eval("return document.getElementById('review-state').textContent")
            .await
    );
    // What the page plotted: the first component's raw and smoothed series (uPlot's own data)
    // and the RMS of their difference; and the cut-off the spectrum marks.
    let plotted = "const plot = document.getElementById('review').teachcamPlots
            .find(p => p.root.closest('section[data-figure=components]'));
        const k = (name) => plot.series.findIndex(s => s.label === name);
        const raw = plot.data[k('raw')], smoothed = plot.data[k('smoothed')];
        let sum = 0, n = 0;
        for (let i = 0; i < raw.length; i += 1) {
            if (raw[i] != null && smoothed[i] != null) { sum += (raw[i] - smoothed[i]) ** 2; n += 1; }
        }
        const spectrum = window.teachcamStudio.reviewFigures.find(f => f.id === 'spectrum');
        const marks = spectrum.panels.flatMap(p => p.marks.map(m => m.label));
        return {residual_rms_mm: Math.sqrt(sum / n), n, marks};";
    let at_6_hz = browser.eval(plotted).await;
    browser
        .eval("const slider = document.getElementById('cutoff'); slider.value = '2'; slider.dispatchEvent(new Event('input')); return true")
        .await;
    ensure!(
        browser
            .wait_for(&drawn_at("2"), Duration::from_secs(20))
            .await,
        "the review redraws at 2 Hz: {}",
        browser
            .eval("return document.getElementById('review-state').textContent")
            .await
    );
    let at_2_hz = browser.eval(plotted).await;
    eprintln!("{test}: review at 6 Hz {at_6_hz}, at 2 Hz {at_2_hz}");
    // The take is the same stroke played back and forth, so the two windows hold the same
    // motion: a 2 Hz low-pass takes the stroke's 2-6 Hz content away as well as the noise
    // (0.02 mm), so what it removes must be clearly more than what 6 Hz removes.
    let rms = |v: &serde_json::Value| v["residual_rms_mm"].as_f64().unwrap_or(f64::NAN);
    ensure!(
        at_6_hz["n"].as_u64().is_some_and(|n| n > 30) && rms(&at_2_hz) > 2.0 * rms(&at_6_hz),
        "moving the cut-off from 6 to 2 Hz changes the smoothed curve: {at_6_hz} then {at_2_hz}"
    );
    ensure!(
        at_2_hz["marks"]
            .as_array()
            .is_some_and(|m| m.iter().any(|l| l == "cut-off 2 Hz")),
        "the spectrum marks the new cut-off: {at_2_hz}"
    );
    // Robot: opening the tab checks the take at once; the simulator's world is not placed
    // for an arm at its origin, so the page starts from the suggested work object and says so.
    browser
        .eval("document.querySelector('nav button[data-tab=robot]').click(); return true")
        .await;
    ensure!(
        browser
            .wait_for(
                &format!("return {studio}.robot !== null && {studio}.robot.passes === true && document.getElementById('export-rapid').hasAttribute('href')"),
                Duration::from_secs(30)
            )
            .await,
        "the tab opens on a passing placement: {}",
        browser.eval("return document.getElementById('robot-summary').textContent").await
    );
    let placement = browser
        .eval("const p = document.getElementById('robot-placement'); return {from: p.dataset.from, text: p.textContent}")
        .await;
    ensure!(
        placement["from"] == "suggested"
            && placement["text"]
                .as_str()
                .is_some_and(|t| t.contains("default work object") && t.contains("suggested")),
        "the page says it started from the suggested placement: {placement}"
    );
    // A work object given at the base fails; the suggestion button puts it right.
    browser
        .eval("document.getElementById('wobj').value = '0,0,0,1,0,0,0'; document.getElementById('robot-check').click(); return true")
        .await;
    ensure!(
        browser
            .wait_for(
                &format!("return {studio}.robot.passes === false && !document.getElementById('use-suggestion').disabled"),
                Duration::from_secs(20)
            )
            .await,
        "the given wobj at the base fails with a suggestion: {}",
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
    // The strokes are listed; the free tool axis is export's, said when chosen.
    browser
        .eval("document.getElementById('free-tool-axis').checked = true; document.getElementById('robot-check').click(); return true")
        .await;
    ensure!(
        browser
            .wait_for(
                "const p = document.getElementById('robot-strokes'); return Number(p.dataset.strokes) >= 1 && p.textContent.includes('tool axis free')",
                Duration::from_secs(30)
            )
            .await,
        "the strokes and the free tool axis are said: {}",
        browser.eval("return document.getElementById('robot-strokes').textContent").await
    );
    browser
        .eval("document.getElementById('free-tool-axis').checked = false; document.getElementById('robot-check').click(); return true")
        .await;
    ensure!(
        browser
            .wait_for(
                &format!("return {studio}.robot.passes === true && !document.getElementById('robot-strokes').textContent.includes('tool axis free') && document.getElementById('export-rapid').hasAttribute('href')"),
                Duration::from_secs(30)
            )
            .await,
        "checked again without the free axis: {}",
        browser.eval("return document.getElementById('robot-summary').textContent").await
    );
    // Calibrate, on a studio given no wand: the tab says how to give one.
    browser
        .eval("document.querySelector('nav button[data-tab=calibrate]').click(); return true")
        .await;
    ensure!(
        browser
            .wait_for(
                "const p = document.getElementById('calib-unavailable'); return !p.hidden && p.textContent.includes('--wand')",
                Duration::from_secs(10)
            )
            .await,
        "the Calibrate tab says how to give a wand: {}",
        browser.eval("return document.getElementById('tab-calibrate').textContent").await
    );
    browser
        .eval("document.querySelector('nav button[data-tab=live]').click(); return true")
        .await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    screenshot(browser, "live-with-arm").await;
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
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let path = dir.path().join("teachcam_studio.mod");
    std::fs::write(&path, &rapid).map_err(|e| e.to_string())?;
    if let Some(Err(output)) = teachcam_testdata::rapidchecker(test, &[path]) {
        return Err(format!("rapidchecker refuses the download: {output}"));
    }
    Ok(())
}

/// The studio opened without its token (a bookmark, a second tab) and with a stale one: the
/// page says how to open it, opens no WebSocket and logs no console error; with the token it
/// runs.
#[tokio::test(flavor = "multi_thread")]
async fn the_studio_without_its_token_says_how_to_open_it() {
    let test = "the_studio_without_its_token_says_how_to_open_it";
    let Some(browser) = Browser::open(test).await else {
        return;
    };
    let out = tempfile::tempdir().expect("a temporary folder");
    let served = support::studio::serve(support::studio::sim_config(out.path(), 12)).await;
    let outcome = async {
        let bare = format!("http://{}/", served.address);
        for (what, url) in [
            ("without a token", bare.clone()),
            ("with a stale token", format!("{bare}?token=0123456789abcdef0123456789abcdef")),
        ] {
            browser
                .client
                .goto(&url)
                .await
                .map_err(|e| format!("the browser opens {url}: {e}"))?;
            ensure!(
                browser
                    .wait_for(
                        "return window.teachcamStudio && window.teachcamStudio.tokenRefused === true",
                        Duration::from_secs(20)
                    )
                    .await,
                "{what}: the page sees its token refused"
            );
            // Give a refused socket or request the time to show in the console.
            tokio::time::sleep(Duration::from_secs(2)).await;
            let shown = browser
                .eval("const box = document.getElementById('no-token'); return {visible: !box.hidden && box.offsetHeight > 0, text: box.textContent, frames: window.teachcamStudio.framesDrawn, tabs: document.querySelector('nav').offsetHeight}")
                .await;
            ensure!(
                shown["visible"] == true
                    && shown["frames"] == 0
                    && shown["tabs"] == 0
                    && shown["text"]
                        .as_str()
                        .is_some_and(|t| t.contains(&format!("http://{}/?token=", served.address))),
                "{what}: the page says how to open it and draws nothing else: {shown}"
            );
            let errors = browser.errors().await;
            ensure!(errors.is_empty(), "{what}: console errors: {errors:?}");
        }
        browser
            .client
            .goto(&served.url())
            .await
            .map_err(|e| format!("the browser opens the studio: {e}"))?;
        ensure!(
            browser
                .wait_for(
                    "return window.teachcamStudio.tokenRefused === false && window.teachcamStudio.framesDrawn > 0 && document.getElementById('no-token').hidden",
                    Duration::from_secs(30)
                )
                .await,
            "with the token the studio runs: {}",
            browser.eval("return window.teachcamStudio").await
        );
        Ok::<(), String>(())
    }
    .await;
    let errors = browser.errors().await;
    browser.close().await;
    served.studio.finish();
    if let Err(message) = outcome {
        panic!("{test}: {message}");
    }
    assert!(errors.is_empty(), "console errors: {errors:?}");
}

/// A recording of one camera and no rig.json opens view-only: its frames, its detections and
/// the detector's measured levels, with no console error; Review, Robot and Record are off.
#[tokio::test(flavor = "multi_thread")]
async fn a_recording_without_a_rig_opens_view_only() {
    let test = "a_recording_without_a_rig_opens_view_only";
    let Some(browser) = Browser::open(test).await else {
        return;
    };
    let dir = tempfile::tempdir().expect("a temporary folder");
    let recording = dir.path().join("rec");
    let mut scene = teachcam::sim::build_scene(teachcam::sim::Scenario::Paper, 1);
    scene.truth.samples.truncate(12);
    teachcam::sim::write_scene(&scene, &recording, 1, &|| {}).expect("the scene renders");
    // One camera, no rig, no tool.
    let mut cameras: Vec<_> = std::fs::read_dir(&recording)
        .expect("the recording")
        .filter_map(Result::ok)
        .filter(|e| e.path().is_dir())
        .map(|e| e.path())
        .collect();
    cameras.sort();
    for extra in &cameras[1..] {
        std::fs::remove_dir_all(extra).expect("removing a camera");
    }
    for file in ["rig.json", "tool.json", "truth.csv"] {
        let _ = std::fs::remove_file(recording.join(file));
    }
    let kept = cameras[0]
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default()
        .to_string();
    let out = tempfile::tempdir().expect("a temporary folder");
    let mut config = support::studio::sim_config(out.path(), 12);
    config.source = teachcam::source::SourceSpec::Folder(recording.clone());
    config.source_config = teachcam::source::SourceConfig::default();
    config.model = teachcam_studio::server::Model::ViewOnly {
        reason: "rec has no rig.json".into(),
    };
    let served = support::studio::serve(config).await;
    let outcome = async {
        browser
            .client
            .goto(&served.url())
            .await
            .map_err(|e| format!("the browser opens the studio: {e}"))?;
        ensure!(
            browser
                .wait_for(
                    "return window.teachcamStudio && window.teachcamStudio.framesDrawn > 30 && window.teachcamStudio.viewOnly !== null",
                    Duration::from_secs(30)
                )
                .await,
            "the frames are drawn view-only: {}",
            browser.eval("return window.teachcamStudio").await
        );
        let shown = browser
            .eval("const cards = Array.from(document.querySelectorAll('#cameras .camera'));
                   return {cameras: cards.map(c => c.querySelector('canvas').dataset.camera),
                           blobs: cards.map(c => Number(c.dataset.blobs)),
                           captions: cards.map(c => c.querySelector('.caption').textContent),
                           banner: document.getElementById('view-only').textContent,
                           status: document.getElementById('pose-status').textContent,
                           review_off: document.querySelector('nav button[data-tab=review]').disabled,
                           record_off: document.getElementById('record').disabled}")
            .await;
        eprintln!("{test}: {shown}");
        ensure!(
            shown["cameras"] == serde_json::json!([kept])
                && shown["blobs"] == serde_json::json!([4])
                && shown["captions"][0]
                    .as_str()
                    .is_some_and(|c| c.contains("background") && c.contains("noise σ") && c.contains("threshold"))
                && shown["banner"].as_str().is_some_and(|b| b.contains("no rig.json"))
                && shown["status"] == "view-only"
                && shown["review_off"] == true
                && shown["record_off"] == true,
            "one camera, its 4 markers' blobs and the measured levels, view-only: {shown}"
        );
        Ok::<(), String>(())
    }
    .await;
    let errors = browser.errors().await;
    browser.close().await;
    served.studio.finish();
    if let Err(message) = outcome {
        panic!("{test}: {message}");
    }
    assert!(errors.is_empty(), "console errors: {errors:?}");
}

/// The Calibrate tab on the simulator's wand dance (100 frames of four cameras) and its
/// L-frame: the coverage fills as the frames are detected, Calibrate gives each camera's RMS
/// and the wand length's error within twice what this dance measures (0.0083-0.0092 px,
/// 0.0054 mm: the rendered blobs' centring noise), the rig is drawn in 3-D and saved where the
/// page asked (a second save is refused until Overwrite), and `teachcam track`'s library run
/// poses the L-frame through the saved rig at the world's origin. No console error.
#[tokio::test(flavor = "multi_thread")]
async fn the_calibrate_tab_calibrates_a_wand_dance_and_saves_the_rig() {
    let test = "the_calibrate_tab_calibrates_a_wand_dance_and_saves_the_rig";
    let Some(browser) = Browser::open(test).await else {
        return;
    };
    let dir = tempfile::tempdir().expect("a temporary folder");
    let sim = dir.path().join("sim");
    teachcam::sim::wand::write_wand_scenario(&sim, 1, Some(100), &|| {})
        .expect("the wand scenario renders");
    let out = dir.path().join("out");
    let mut config = support::studio::sim_config(&out, 12);
    let lframe = teachcam::io::tool::read_tool(&sim.join("lframe.json")).expect("the L-frame");
    config.wand = Some(teachcam_studio::server::calibrate::WandSetup {
        cameras: teachcam::io::rig::read_cameras(&sim.join("cameras.json")).expect("cameras"),
        wand: teachcam::io::wand::read_wand(&sim.join("wand.json")).expect("the wand"),
        recording: Some(sim.join("wand")),
        ground_tool: Some(lframe.clone()),
        ground: Some(sim.join("ground")),
        near_mm: 300.0,
        far_mm: 3000.0,
    });
    let served = support::studio::serve(config).await;
    let outcome = async {
        browser
            .client
            .goto(&format!("{}#calibrate", served.url()))
            .await
            .map_err(|e| format!("the browser opens the studio: {e}"))?;
        ensure!(
            browser
                .wait_for(
                    "return !document.getElementById('calib-panel').hidden && document.getElementById('calib-recording').value === 'wand' && document.getElementById('calib-ground').value === 'ground'",
                    Duration::from_secs(20)
                )
                .await,
            "the tab offers the dance and the ground frame: {}",
            browser.eval("return window.teachcamStudio.calibration").await
        );
        browser
            .eval("document.getElementById('calibrate').click(); return true")
            .await;
        ensure!(
            browser
                .wait_for(
                    "return document.getElementById('calib-state').dataset.stage === 'done' && window.teachcamStudio.calibrationRenders > 0",
                    Duration::from_secs(120)
                )
                .await,
            "the calibration ends: {}",
            browser.eval("return document.getElementById('calib-state').textContent").await
        );
        screenshot(&browser, "calibrate").await;
        browser
            .eval("document.getElementById('calib-scene').scrollIntoView(); return true")
            .await;
        screenshot(&browser, "calibrate-rig").await;
        // The coverage filled as the frames came, and covers each camera's image.
        let coverage = browser
            .eval("return {history: window.teachcamStudio.coverageHistory,
                           cells: Array.from(document.querySelectorAll('#calib-coverage canvas')).map(c => Number(c.dataset.filled)),
                           views: window.teachcamStudio.calibration.coverage.map(c => c.views)}")
            .await;
        let history: Vec<f64> = coverage["history"]
            .as_array()
            .map(|h| h.iter().filter_map(serde_json::Value::as_f64).collect())
            .unwrap_or_default();
        ensure!(
            !history.is_empty() && history.windows(2).all(|w| w[0] <= w[1]),
            "the coverage fills as the frames are detected: {coverage}"
        );
        let cells: Vec<u64> = coverage["cells"]
            .as_array()
            .map(|c| c.iter().filter_map(serde_json::Value::as_u64).collect())
            .unwrap_or_default();
        // The 100 frames cross part of each image: measured 11-19 of 48 cells (about half).
        ensure!(
            cells.len() == 4 && cells.iter().all(|c| *c >= 6),
            "each camera's coverage: {coverage}"
        );
        let result = browser
            .eval("return window.teachcamStudio.calibration.result")
            .await;
        for camera in result["cameras"].as_array().into_iter().flatten() {
            let rms = camera["rms_px"].as_f64().unwrap_or(f64::NAN);
            ensure!(
                rms.is_finite() && rms < 0.02,
                "{}: RMS {rms} px",
                camera["name"]
            );
        }
        let length_rms = result["length_error_rms_mm"].as_f64().unwrap_or(f64::NAN);
        ensure!(
            length_rms.is_finite() && length_rms < 0.012,
            "wand length error RMS {length_rms} mm"
        );
        let shown = browser
            .eval("return document.querySelectorAll('#calib-cameras tr[data-camera]').length")
            .await;
        ensure!(shown == 4, "a row per camera: {shown}");
        // Saving asks first, then writes; a second save of the name asks to overwrite.
        let saved = out.join("rig.json");
        browser
            .eval("document.getElementById('calib-save').click(); return true")
            .await;
        ensure!(
            !saved.exists()
                && browser
                    .wait_for(
                        "return !document.getElementById('calib-confirm').hidden",
                        Duration::from_secs(5)
                    )
                    .await,
            "Save asks for confirmation before writing"
        );
        browser
            .eval("document.getElementById('calib-confirm').click(); return true")
            .await;
        ensure!(
            browser
                .wait_for(
                    "return (document.getElementById('calib-saved').dataset.path || '').endsWith('rig.json')",
                    Duration::from_secs(10)
                )
                .await
                && saved.is_file(),
            "the rig is saved: {}",
            browser.eval("return document.getElementById('calib-saved').textContent").await
        );
        std::fs::write(&saved, "kept").map_err(|e| e.to_string())?;
        browser
            .eval("document.getElementById('calib-save').click(); document.getElementById('calib-confirm').click(); return true")
            .await;
        ensure!(
            browser
                .wait_for(
                    "return !document.getElementById('calib-overwrite').hidden",
                    Duration::from_secs(10)
                )
                .await
                && std::fs::read_to_string(&saved).map_err(|e| e.to_string())? == "kept",
            "an existing file is kept until Overwrite: {}",
            browser.eval("return document.getElementById('calib-saved').textContent").await
        );
        browser
            .eval("document.getElementById('calib-overwrite').click(); return true")
            .await;
        ensure!(
            browser
                .wait_for(
                    "return document.getElementById('calib-overwrite').hidden",
                    Duration::from_secs(10)
                )
                .await,
            "Overwrite saves"
        );
        // `teachcam track`'s run poses the L-frame through the saved rig, at the world's origin.
        let rig = teachcam::io::rig::read_rig(&saved).map_err(|e| e.to_string())?;
        let run = teachcam::pipeline::batch::track(
            teachcam::pipeline::batch::TrackInput::Recording(&sim.join("ground")),
            &rig,
            &lframe,
            &teachcam::pipeline::batch::TrackOptions::default(),
            &|| {},
        )
        .map_err(|e| format!("track through the saved rig: {e}"))?;
        let origins: Vec<f64> = run
            .trajectory
            .samples
            .iter()
            .filter_map(|s| s.pose.map(|p| p.world_from_tool.translation.vector.norm()))
            .collect();
        ensure!(
            origins.len() == run.trajectory.len() && origins.iter().all(|d| *d < 0.05),
            "the L-frame at the world's origin in every frame: {origins:?}"
        );
        Ok::<(), String>(())
    }
    .await;
    let errors = browser.errors().await;
    browser.close().await;
    served.studio.finish();
    if let Err(message) = outcome {
        panic!("{test}: {message}");
    }
    assert!(errors.is_empty(), "console errors: {errors:?}");
}

/// A small simulated run (the paper's rig, the first 36 frames of its stroke rendered; the
/// truth with 0.02 mm of noise as the tracked trajectory) and its report, written to `dir`.
#[expect(
    clippy::expect_used,
    reason = "a test fails loudly on a broken fixture"
)]
fn simulated_report(dir: &std::path::Path) -> teachcam::report::Report {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use teachcam::report::{Absent, Header, InputFile, ReportInputs, build_report};

    let mut scene = teachcam::sim::build_scene(teachcam::sim::Scenario::Paper, 1);
    scene.truth.samples.truncate(36);
    let recording = dir.join("recording");
    teachcam::sim::write_scene(&scene, &recording, 1, &|| {}).expect("the scene renders");
    let mut raw = scene.truth.clone();
    let normal = Normal::new(0.0, 0.02).expect("a normal distribution");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
    for s in &mut raw.samples {
        let p = s.pose.as_mut().expect("the truth has every pose");
        let tip_in_tool = p.world_from_tool.inverse_transform_point(&p.tip_in_world);
        let mut t = p.world_from_tool.translation.vector;
        for c in 0..3 {
            t[c] += normal.sample(&mut rng);
        }
        p.world_from_tool = teachcam::geometry::pose_from_parts(t, p.world_from_tool.rotation);
        p.tip_in_world = p.world_from_tool * tip_in_tool;
        s.tip_std_mm = Some(0.02);
    }
    let input = |role: &str, path: &std::path::Path| InputFile {
        role: role.into(),
        path: Some(path.display().to_string()),
        note: String::new(),
    };
    // The path on the IRB 120 as the demo places it, checked as `teachcam check` does.
    let targets =
        teachcam::robot::tcp_targets(&raw, &teachcam::geometry::Pose::identity().rotation);
    let cell = teachcam::robot::Cell {
        base_from_wobj: teachcam::geometry::parse_pose("350,0,100,1,0,0,0").expect("a pose"),
        flange_from_tcp: teachcam::geometry::parse_pose("0,0,200,0,1,0,0").expect("a pose"),
    };
    let config = teachcam::robot::check::CheckConfig::default();
    let robot = teachcam::robot::kinematics::Robot::by_name("irb120").expect("the IRB 120");
    let whole = 0..targets.len();
    let strokes = std::slice::from_ref(&whole);
    let check = teachcam::robot::check::check_strokes(&robot, &cell, &targets, strokes, &config);
    let joints =
        teachcam::report::joints::CheckedJoints::new(check, strokes, config.speed_fraction);
    build_report(&ReportInputs {
        header: Header::now(vec![
            input("recording", &recording),
            InputFile {
                role: "smoothed trajectory".into(),
                path: None,
                note: "no smoothed.csv <here> & there".into(),
            },
        ]),
        raw: &raw,
        // A missing input: its slot must say why, and the page must draw that line.
        smoothed: Err(Absent("no smoothed.csv".into())),
        truth: Ok(&scene.truth),
        rig: Ok(&scene.rig),
        tool: Ok(&scene.tool),
        recording: Ok(recording.as_path()),
        base_from_wobj: Err(Absent("no work object </script> given (--wobj)".into())),
        joints: Ok(&joints),
        cutoff_hz: 10.0,
        study_seed: 1,
        extra_summary: Vec::new(),
    })
}

#[tokio::test(flavor = "multi_thread")]
async fn the_report_draws_every_figure_and_zooms() {
    let test = "the_report_draws_every_figure_and_zooms";
    let dir = tempfile::tempdir().expect("a temporary folder");
    let report = simulated_report(dir.path());
    let page = dir.path().join("report.html");
    let html = teachcam_studio::report_page::render(&report).expect("the page renders");
    std::fs::write(&page, &html).expect("writing the page");
    if let Some(keep) = std::env::var_os("TEACHCAM_KEEP_REPORT") {
        std::fs::write(keep, &html).expect("keeping the page");
    }
    let Some(browser) = Browser::open(test).await else {
        return;
    };
    let drawn = browser.drawn_report(&page).await;
    let errors = browser.errors().await;
    assert!(errors.is_empty(), "console errors: {errors:?}");
    // Every slot of the model has its section; every panel its uPlot canvas; every missing
    // slot its line.
    let model = serde_json::to_value(&report.figures).expect("the model as JSON");
    if let Err(wrong) =
        teachcam_testdata::browser::check_figures_drawn(model.as_array().expect("a list"), &drawn)
    {
        panic!("{wrong}");
    }
    // The joint figure: an angle and a speed panel for each of the 6 axes, each plotted over
    // a range that holds its limit lines.
    let joints = drawn
        .iter()
        .find(|s| s["id"] == "joints")
        .expect("the joint figure");
    assert_eq!(joints["canvases"], 12, "{joints}");
    let slot = model
        .as_array()
        .and_then(|m| m.iter().find(|s| s["id"] == "joints"))
        .expect("the joint slot");
    let limits: Vec<Vec<f64>> = slot["panels"]
        .as_array()
        .expect("panels")
        .iter()
        .map(|p| {
            p["marks"]
                .as_array()
                .expect("marks")
                .iter()
                .filter_map(|m| m["y"].as_f64())
                .collect()
        })
        .collect();
    assert!(
        limits.iter().all(|l| l.len() >= 2),
        "limit lines: {limits:?}"
    );
    let ranges = browser
        .eval(
            "const section = document.getElementById('figures');
             return Array.from(document.querySelectorAll('section[data-figure=joints] .uplot'))
               .map(u => section.teachcamPlots.find(p => p.root === u))
               .map(p => [p.scales.y.min, p.scales.y.max]);",
        )
        .await;
    for (range, lines) in ranges.as_array().expect("the ranges").iter().zip(&limits) {
        let (low, high) = (
            range[0].as_f64().unwrap_or(f64::NAN),
            range[1].as_f64().unwrap_or(f64::NAN),
        );
        assert!(
            lines.iter().all(|y| (low..=high).contains(y)),
            "the plotted range {low}..{high} leaves out a limit line of {lines:?}"
        );
    }
    let robot = drawn
        .iter()
        .find(|s| s["id"] == "robot")
        .expect("the robot slot");
    assert!(
        robot["missing"]
            .as_str()
            .unwrap_or_default()
            .contains("</script>")
    );
    // The paths are to scale: as many millimetres per pixel across as up.
    let aspect = browser
        .eval(
            "const u = document.querySelector('section[data-figure=paths] .uplot');
             const section = document.getElementById('figures');
             const p = section.teachcamPlots.find(p => p.root === u);
             return [(p.scales.x.max - p.scales.x.min) / p.bbox.width,
                     (p.scales.y.max - p.scales.y.min) / p.bbox.height];",
        )
        .await;
    let (across, up) = (
        aspect[0].as_f64().unwrap_or(0.0),
        aspect[1].as_f64().unwrap_or(1.0),
    );
    assert!((across - up).abs() < 1e-9 * across.abs(), "{aspect}");
    // Hover the first component plot: its legend shows the values under the cursor.
    let over = browser
        .client
        .find(fantoccini::Locator::Css(
            "section[data-figure=components] .u-over",
        ))
        .await
        .expect("the first plot's overlay");
    let before = browser
        .eval("return document.querySelector('section[data-figure=components] .u-legend').textContent")
        .await;
    // Drag across the middle of the plot: a zoom on x.
    use fantoccini::actions::InputSource as _;
    let actions = fantoccini::actions::MouseActions::new("mouse".into())
        .then(fantoccini::actions::PointerAction::MoveToElement {
            element: over.clone(),
            duration: None,
            x: -100.0,
            y: 0.0,
        })
        .then(fantoccini::actions::PointerAction::Down {
            button: fantoccini::actions::MOUSE_BUTTON_LEFT,
        })
        .then(fantoccini::actions::PointerAction::MoveToElement {
            element: over,
            duration: Some(Duration::from_millis(200)),
            x: 100.0,
            y: 0.0,
        })
        .then(fantoccini::actions::PointerAction::Up {
            button: fantoccini::actions::MOUSE_BUTTON_LEFT,
        });
    browser
        .client
        .perform_actions(actions)
        .await
        .expect("the drag");
    let after = browser
        .eval(
            "const section = document.getElementById('figures');
             const u = document.querySelector('section[data-figure=components] .uplot');
             const p = section.teachcamPlots.find(p => p.root === u);
             return [p.scales.x.min, p.scales.x.max, p.data[0][0], p.data[0][p.data[0].length - 1],
                     document.querySelector('section[data-figure=components] .u-legend').textContent];",
        )
        .await;
    let (min, max, first, last) = (
        after[0].as_f64().unwrap_or(0.0),
        after[1].as_f64().unwrap_or(0.0),
        after[2].as_f64().unwrap_or(0.0),
        after[3].as_f64().unwrap_or(0.0),
    );
    assert!(
        min > first && max < last && max > min,
        "zoomed to {after} from {first}..{last}"
    );
    assert_ne!(
        before, after[4],
        "the legend shows the values under the cursor"
    );
    let errors = browser.errors().await;
    assert!(errors.is_empty(), "console errors: {errors:?}");
    browser.close().await;
}
