//! Reading a report page from the CLI tests (`#[path = "support/report.rs"] mod report;`):
//! the model it inlines, and the check that every figure is drawn.

/// The report model inlined in `page` as JSON.
pub fn model_of(page: &str) -> serde_json::Value {
    let start_tag = "<script type=\"application/json\" id=\"teachcam-report\">";
    let start = page.find(start_tag).expect("the page inlines its model") + start_tag.len();
    let end = start
        + page[start..]
            .find("</script>")
            .expect("the model's block ends");
    serde_json::from_str(&page[start..end]).expect("the inlined model is JSON")
}

/// Every figure of the report is drawn (none is a "missing" slot), listed in the page's
/// contents, and nothing is fetched from elsewhere.
pub fn assert_every_figure_drawn(page: &str) {
    let model = model_of(page);
    let figures = model["figures"].as_array().expect("a list of figures");
    let ids: Vec<&str> = figures.iter().filter_map(|f| f["id"].as_str()).collect();
    assert_eq!(
        ids,
        [
            "components",
            "spectrum",
            "quality",
            "smoothing_study",
            "paths",
            "robot",
            "joints",
            "tip_error",
            "uncertainty",
            "cameras"
        ]
    );
    for f in figures {
        assert_ne!(f["kind"], "missing", "{}: {}", f["id"], f["reason"]);
        assert!(
            page.contains(&format!(
                "<li data-figure=\"{}\">",
                f["id"].as_str().unwrap_or("")
            )),
            "{} is not in the page's contents",
            f["id"]
        );
    }
    // (uPlot's licence comment names its home page; nothing loads from a network.)
    for fetch in ["src=\"http", "href=\"http", "url(http", "fetch(", "<link"] {
        assert!(
            !page.contains(fetch),
            "the page fetches from elsewhere: {fetch}"
        );
    }
}
