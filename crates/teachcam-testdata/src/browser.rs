//! Headless Chromium for the browser tests: Debian's `chromium` driven through its
//! `chromedriver` (WebDriver, by `fantoccini`), on a free loopback port, one session per test.
//!
//! Where the browser is not installed the test says it was skipped; under `CI=true` that is a
//! failure (`.ci/run` installs both packages).
//!
//! Test support: a failure here is a failed test, so it panics with what went wrong.
#![allow(clippy::expect_used, clippy::unwrap_used, clippy::print_stderr)]

use std::net::TcpListener;
use std::os::unix::process::CommandExt as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fantoccini::wd::{Capabilities, WebDriverCompatibleCommand};
use fantoccini::{Client, ClientBuilder};
use serde_json::{Value, json};

/// How long chromedriver may take to answer after it starts.
const DRIVER_START: Duration = Duration::from_secs(20);

/// A browser session and the chromedriver serving it (stopped on drop).
#[derive(Debug)]
pub struct Browser {
    /// The WebDriver session.
    pub client: Client,
    driver: Child,
}

/// The first of `names` found on the PATH or in /usr/bin.
fn program(names: &[&str]) -> Option<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    let dirs = std::env::split_paths(&path).chain([PathBuf::from("/usr/bin")]);
    let dirs: Vec<PathBuf> = dirs.collect();
    names
        .iter()
        .flat_map(|name| dirs.iter().map(move |dir| dir.join(name)))
        .find(|candidate| candidate.is_file())
}

/// A loopback port nobody listens on now.
fn free_port() -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").expect("a free loopback port");
    listener.local_addr().expect("its address").port()
}

/// chromedriver's own command for the browser's console log (`POST /session/{id}/se/log`).
#[derive(Debug)]
struct BrowserLog;

impl WebDriverCompatibleCommand for BrowserLog {
    fn endpoint(
        &self,
        base_url: &url::Url,
        session_id: Option<&str>,
    ) -> Result<url::Url, url::ParseError> {
        base_url.join(&format!(
            "session/{}/se/log",
            session_id.unwrap_or_default()
        ))
    }

    fn method_and_body(&self, _request_url: &url::Url) -> (http::Method, Option<String>) {
        (
            http::Method::POST,
            Some(json!({"type": "browser"}).to_string()),
        )
    }
}

impl Browser {
    /// Starts headless Chromium, or says why `test` is skipped and returns None (a failure
    /// under `CI=true`).
    pub async fn open(test: &str) -> Option<Browser> {
        let (Some(chromium), Some(chromedriver)) = (
            program(&["chromium", "chromium-browser", "google-chrome"]),
            program(&["chromedriver"]),
        ) else {
            let why = "chromium and chromedriver are not installed \
                       (apt-get install chromium chromium-driver)";
            crate::skipped(test, why);
            return None;
        };
        let port = free_port();
        // A process group of its own, so that the browsers chromedriver starts end with it
        // (`Drop`), even when a test panics before `close`.
        let driver = Command::new(&chromedriver)
            .arg(format!("--port={port}"))
            .process_group(0)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("{test}: starting {}: {e}", chromedriver.display()));
        let mut capabilities = Capabilities::new();
        capabilities.insert(
            "goog:chromeOptions".into(),
            json!({
                "binary": chromium,
                "args": [
                    "--headless=new",
                    "--no-sandbox",
                    "--disable-dev-shm-usage",
                    "--disable-background-networking",
                    "--disable-extensions",
                    "--no-first-run",
                    "--window-size=1280,900",
                    // WebGL without a GPU: ANGLE on SwiftShader, the software renderer.
                    "--use-angle=swiftshader",
                    "--enable-unsafe-swiftshader",
                ],
            }),
        );
        capabilities.insert("goog:loggingPrefs".into(), json!({"browser": "ALL"}));
        let connector = hyper_util::client::legacy::connect::HttpConnector::new();
        let url = format!("http://127.0.0.1:{port}");
        let started = Instant::now();
        Some(Browser {
            client: loop {
                match ClientBuilder::new(connector.clone())
                    .capabilities(capabilities.clone())
                    .connect(&url)
                    .await
                {
                    Ok(client) => break client,
                    Err(e) if started.elapsed() > DRIVER_START => {
                        panic!("{test}: chromedriver did not start a session: {e}")
                    }
                    Err(_) => tokio::time::sleep(Duration::from_millis(100)).await,
                }
            },
            driver,
        })
    }

    /// The browser's console entries since the last call, as `LEVEL message` lines.
    pub async fn console(&self) -> Vec<String> {
        let log = self
            .client
            .issue_cmd(BrowserLog)
            .await
            .expect("chromedriver's browser log");
        log.as_array()
            .map(|entries| {
                entries
                    .iter()
                    .map(|e| format!("{} {}", e["level"].as_str().unwrap_or("?"), e["message"]))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// The console errors (level SEVERE) since the last call to `console` or `errors`.
    pub async fn errors(&self) -> Vec<String> {
        let mut all = self.console().await;
        all.retain(|line| line.starts_with("SEVERE"));
        all
    }

    /// Opens a local file.
    pub async fn open_file(&self, path: &Path) {
        let path = path.canonicalize().expect("the page's file exists");
        self.client
            .goto(&format!("file://{}", path.display()))
            .await
            .expect("the browser opens the page");
    }

    /// Evaluates `script` (a function body: `return …`) in the page.
    pub async fn eval(&self, script: &str) -> Value {
        self.client
            .execute(script, vec![])
            .await
            .unwrap_or_else(|e| panic!("running {script:?} in the page: {e}"))
    }

    /// Waits until `script` returns true, for at most `timeout`; returns whether it did.
    pub async fn wait_for(&self, script: &str, timeout: Duration) -> bool {
        let started = Instant::now();
        while started.elapsed() < timeout {
            if self.eval(script).await == Value::Bool(true) {
                return true;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        false
    }

    /// Ends the session, chromedriver and the browser.
    pub async fn close(self) {
        let _ = self.client.clone().close().await;
        // `Drop` ends the process group.
    }

    /// Kills chromedriver's whole process group: chromedriver, Chromium and its helpers.
    fn kill_group(&mut self) {
        let _ = Command::new("kill")
            .args(["-KILL", "--", &format!("-{}", self.driver.id())])
            .stderr(Stdio::null())
            .status();
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        self.kill_group();
    }
}

/// What a report page drew: one entry per `section.tc-figure` of `#figures`, with its id, its
/// uPlot canvases, its loaded images and its "missing" line.
const DRAWN_FIGURES: &str = "return Array.from(document.querySelectorAll('#figures section.tc-figure')).map(s => ({
    id: s.dataset.figure,
    canvases: s.querySelectorAll('.uplot canvas').length,
    images: Array.from(s.querySelectorAll('img')).filter(i => i.complete && i.naturalWidth > 0).length,
    missing: (s.querySelector('.tc-missing') || {}).textContent || null,
}))";

impl Browser {
    /// Opens the report page at `page` and waits for its figures; returns what it drew
    /// ([`check_figures_drawn`] compares it with the page's model).
    pub async fn drawn_report(&self, page: &Path) -> Vec<Value> {
        self.open_file(page).await;
        assert!(
            self.wait_for(
                "return document.querySelectorAll('#figures section.tc-figure').length > 0",
                Duration::from_secs(20)
            )
            .await,
            "{}: no figure was drawn",
            page.display()
        );
        match self.eval(DRAWN_FIGURES).await {
            Value::Array(sections) => sections,
            other => panic!("{}: the page's sections: {other}", page.display()),
        }
    }
}

/// Every figure slot of a report model (`figures`, its JSON list) has its section, in order:
/// a uPlot canvas for each plot panel, each image loaded, or the line saying why it is missing.
///
/// # Errors
/// The first slot drawn otherwise, with what was drawn.
pub fn check_figures_drawn(figures: &[Value], drawn: &[Value]) -> Result<(), String> {
    if figures.len() != drawn.len() {
        return Err(format!(
            "{} figure slots, {} sections drawn: {drawn:?}",
            figures.len(),
            drawn.len()
        ));
    }
    for (slot, section) in figures.iter().zip(drawn) {
        let expected = match slot["kind"].as_str() {
            Some("plots") => json!({"canvases": slot["panels"].as_array().map_or(0, Vec::len)}),
            Some("images") => json!({"images": slot["images"].as_array().map_or(0, Vec::len)}),
            Some("missing") => json!({"missing": format!(
                "Missing: {}",
                slot["reason"].as_str().unwrap_or_default()
            )}),
            other => return Err(format!("{}: unknown kind {other:?}", slot["id"])),
        };
        let matches = section["id"] == slot["id"]
            && expected
                .as_object()
                .is_some_and(|e| e.iter().all(|(k, v)| &section[k] == v));
        if !matches {
            return Err(format!(
                "{} expected {expected}, drawn {section}",
                slot["id"]
            ));
        }
    }
    Ok(())
}

/// The whole browser check of a report page, for tests without an async runtime (the CLI's):
/// opens `page` in headless Chromium, asserts that no console error was logged and that every
/// slot of `figures` (the page's model, its JSON list) was drawn as [`check_figures_drawn`]
/// asks. Says the test was skipped where the browser is not installed (a failure under
/// `CI=true`).
pub fn assert_report_drawn(test: &str, page: &Path, figures: &[Value]) {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("a runtime for the browser session");
    runtime.block_on(async {
        let Some(browser) = Browser::open(test).await else {
            return;
        };
        let drawn = browser.drawn_report(page).await;
        let errors = browser.errors().await;
        browser.close().await;
        assert!(errors.is_empty(), "{test}: console errors: {errors:?}");
        if let Err(wrong) = check_figures_drawn(figures, &drawn) {
            panic!("{test}: {wrong}");
        }
    });
}
