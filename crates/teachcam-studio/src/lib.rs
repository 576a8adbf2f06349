//! teachcam studio: the local web app (cameras, 3-D view, record, review, robot, export) and the
//! interactive report page.
//!
//! This crate holds the async runtime (tokio, axum) so that the core library stays synchronous.
//! What the pages show is computed by the core library (`teachcam::report`); this crate serves
//! it and draws it. The web assets (the pages, and three.js and uPlot vendored with their
//! licences under `web/vendor/`) are compiled into the binary: nothing is fetched from a network.

pub mod assets;
pub mod report_page;
pub mod server;
