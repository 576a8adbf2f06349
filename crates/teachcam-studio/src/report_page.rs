//! The report page: one self-contained HTML file of a run's figures.
//!
//! The page is the report model (`teachcam::report::Report`) inlined as JSON, uPlot and the
//! review script (`web/review.js`, shared with the studio's Review tab) inlined, and a
//! header, summary and list of figures written as HTML so that they read without scripts.
//! Nothing is fetched: the file opens from a disk, offline. Every text from the model is
//! HTML-escaped; the JSON is escaped so that no `</script>` (or `<!--`) can end its block.

use std::fmt::Write as _;

use teachcam::report::{FigureBody, Report};

use crate::assets::{REVIEW_JS, UPLOT_CSS, UPLOT_JS};

/// `text` with `& < > " '` escaped, for HTML text and attribute values.
#[must_use]
pub fn escape_html(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// `value` as JSON safe inside a `<script>` element: `<`, `>` and `&` written as `\u003c`,
/// `\u003e`, `\u0026` (the same JSON to a parser), and U+2028/U+2029 escaped too.
///
/// # Errors
/// When `value` does not serialise (a non-string map key).
pub fn script_json<T: serde::Serialize + ?Sized>(value: &T) -> Result<String, serde_json::Error> {
    let json = serde_json::to_string(value)?;
    let mut out = String::with_capacity(json.len() + 64);
    for c in json.chars() {
        match c {
            '<' => out.push_str("\\u003c"),
            '>' => out.push_str("\\u003e"),
            '&' => out.push_str("\\u0026"),
            '\u{2028}' => out.push_str("\\u2028"),
            '\u{2029}' => out.push_str("\\u2029"),
            c => out.push(c),
        }
    }
    Ok(out)
}

const PAGE_CSS: &str = "body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}\
table{border-collapse:collapse;margin:.5em 0 1.5em}td,th{padding:2px 12px 2px 0;border-bottom:1px solid #eee;text-align:left;vertical-align:top}\
th{font-weight:600}#contents li.missing{color:#8a4b00}code{font-size:.95em}";

/// The whole page.
///
/// # Errors
/// When the model does not serialise (it always does: a guard, not an expected failure).
pub fn render(report: &Report) -> Result<String, serde_json::Error> {
    let json = script_json(report)?;
    let mut page = String::with_capacity(json.len() + UPLOT_JS.len() + REVIEW_JS.len() + 8192);
    page.push_str("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n");
    page.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
    page.push_str("<title>teachcam report</title>\n<style>");
    page.push_str(UPLOT_CSS);
    page.push_str("</style>\n<style>");
    page.push_str(PAGE_CSS);
    page.push_str("</style>\n</head><body>\n<h1>teachcam report</h1>\n");

    let header = &report.header;
    page.push_str("<table id=\"header\">\n");
    let _ = writeln!(
        page,
        "<tr><th>made</th><td>{} by teachcam {}</td></tr>",
        escape_html(&header.created_utc),
        escape_html(&header.teachcam_version)
    );
    for input in &header.inputs {
        let shown = match &input.path {
            Some(path) => format!("<code>{}</code>", escape_html(path)),
            None => format!("not found: {}", escape_html(&input.note)),
        };
        let _ = writeln!(
            page,
            "<tr><th>{}</th><td>{shown}</td></tr>",
            escape_html(&input.role)
        );
    }
    page.push_str("</table>\n<h2>Summary</h2>\n<table id=\"summary\">\n");
    for item in &report.summary {
        let _ = writeln!(
            page,
            "<tr data-key=\"{}\"><th>{}</th><td>{}</td></tr>",
            escape_html(&item.key),
            escape_html(&item.label),
            escape_html(&item.text)
        );
    }
    page.push_str("</table>\n<h2>Figures</h2>\n<ol id=\"contents\">\n");
    for figure in &report.figures {
        match &figure.body {
            FigureBody::Missing { reason } => {
                let _ = writeln!(
                    page,
                    "<li class=\"missing\" data-figure=\"{}\">{}: missing: {}</li>",
                    figure.id.name(),
                    escape_html(&figure.title),
                    escape_html(reason)
                );
            }
            _ => {
                let _ = writeln!(
                    page,
                    "<li data-figure=\"{}\">{}</li>",
                    figure.id.name(),
                    escape_html(&figure.title)
                );
            }
        }
    }
    page.push_str("</ol>\n<noscript><p>The figures are drawn by the page's own script (uPlot, inlined): allow scripts for this file to see them.</p></noscript>\n");
    page.push_str("<main id=\"figures\"></main>\n");
    page.push_str("<script type=\"application/json\" id=\"teachcam-report\">");
    page.push_str(&json);
    page.push_str("</script>\n<script>");
    page.push_str(UPLOT_JS);
    page.push_str("</script>\n<script>");
    page.push_str(REVIEW_JS);
    page.push_str("</script>\n<script>\n(function () {\n  var report = JSON.parse(document.getElementById('teachcam-report').textContent);\n  window.teachcamReview.draw(document.getElementById('figures'), report.figures);\n})();\n</script>\n</body></html>\n");
    Ok(page)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_cannot_end_its_script_block() {
        let json = script_json(
            &serde_json::json!({"caption": "</script><script>alert(1)</script> <!-- & \u{2028}"}),
        )
        .unwrap_or_default();
        assert!(!json.to_ascii_lowercase().contains("</script"));
        assert!(!json.contains("<!--"));
        let back: serde_json::Value = serde_json::from_str(&json).unwrap_or_default();
        assert_eq!(
            back["caption"],
            "</script><script>alert(1)</script> <!-- & \u{2028}"
        );
    }

    #[test]
    fn inlined_scripts_hold_no_end_tag() {
        for (name, script) in [("uPlot", UPLOT_JS), ("review.js", REVIEW_JS)] {
            assert!(
                !script.to_ascii_lowercase().contains("</script"),
                "{name} would end its block"
            );
        }
    }

    #[test]
    fn html_text_is_escaped() {
        assert_eq!(
            escape_html("<b a=\"1\">&'"),
            "&lt;b a=&quot;1&quot;&gt;&amp;&#39;"
        );
    }
}
