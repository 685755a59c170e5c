//! A report as one self-contained HTML page: headings, paragraphs, tables, a verdict box and the
//! plots embedded as PNG `data:` URIs, styled inline. Nothing is fetched (no script, no font, no
//! stylesheet from elsewhere), so the file opens in any browser with nothing else installed and
//! can be filed as it is. Every text is escaped; the page's markup is this module's alone.

use crate::error::PlotError;
use base64::Engine as _;
use image::RgbImage;
use std::fmt::Write as _;

/// The page's style: plain, printable, system fonts only.
const STYLE: &str = "body{font-family:sans-serif;max-width:62em;margin:2em auto;padding:0 1em;color:#222;line-height:1.4}\
h1{font-size:1.6em;border-bottom:2px solid #ccc;padding-bottom:.2em}h2{font-size:1.25em;margin-top:1.6em}\
table{border-collapse:collapse;margin:.6em 0}td,th{border:1px solid #bbb;padding:.25em .6em;text-align:left}\
th{background:#eee}td{white-space:nowrap}td:last-child{white-space:normal}td.n{text-align:right;font-variant-numeric:tabular-nums}\
.verdict{font-size:1.3em;font-weight:bold;padding:.6em 1em;margin:1em 0;border-radius:4px}\
.pass{background:#d9f2d9;border:2px solid #2e7d32;color:#1b5e20}.fail{background:#fde0e0;border:2px solid #c62828;color:#8e0000}\
.note{background:#f4f4f4;border-left:4px solid #888;padding:.5em 1em}img{max-width:100%;height:auto;border:1px solid #ddd}\
figure{margin:1em 0}figcaption{color:#555;font-size:.9em}";

/// `text` safe inside an HTML element or a quoted attribute.
pub fn escape(text: &str) -> String {
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

/// One report page, built in reading order.
#[derive(Debug, Clone)]
pub struct Page {
    title: String,
    body: String,
}

impl Page {
    /// A page titled `title` (its `<title>` and first heading).
    pub fn new(title: impl Into<String>) -> Page {
        let title = title.into();
        let body = format!("<h1>{}</h1>\n", escape(&title));
        Page { title, body }
    }

    /// A section heading.
    pub fn heading(&mut self, text: &str) -> &mut Page {
        let _ = writeln!(self.body, "<h2>{}</h2>", escape(text));
        self
    }

    pub fn paragraph(&mut self, text: &str) -> &mut Page {
        let _ = writeln!(self.body, "<p>{}</p>", escape(text));
        self
    }

    /// A boxed note (what the coordinates are, where the data came from).
    pub fn note(&mut self, text: &str) -> &mut Page {
        let _ = writeln!(self.body, "<p class=\"note\">{}</p>", escape(text));
        self
    }

    /// The verdict, in a green (pass) or red (fail) box with the id `verdict`.
    pub fn verdict(&mut self, pass: bool, text: &str) -> &mut Page {
        let _ = writeln!(
            self.body,
            "<div id=\"verdict\" class=\"verdict {}\">{}</div>",
            if pass { "pass" } else { "fail" },
            escape(text)
        );
        self
    }

    /// A bulleted list.
    pub fn list<S: AsRef<str>>(&mut self, items: &[S]) -> &mut Page {
        self.body.push_str("<ul>\n");
        for i in items {
            let _ = writeln!(self.body, "<li>{}</li>", escape(i.as_ref()));
        }
        self.body.push_str("</ul>\n");
        self
    }

    /// A table: its header and rows (a cell that reads as a number is set right-aligned).
    pub fn table<S: AsRef<str>>(&mut self, header: &[&str], rows: &[Vec<S>]) -> &mut Page {
        self.body.push_str("<table>\n");
        // A header of empty cells (a table of names and values) is left out.
        if header.iter().any(|h| !h.is_empty()) {
            self.body.push_str("<tr>");
            for h in header {
                let _ = write!(self.body, "<th>{}</th>", escape(h));
            }
            self.body.push_str("</tr>\n");
        }
        for row in rows {
            self.body.push_str("<tr>");
            for cell in row {
                let cell = cell.as_ref();
                let numeric = cell.trim_end_matches([' ', '%']).parse::<f64>().is_ok();
                let _ = write!(
                    self.body,
                    "<td{}>{}</td>",
                    if numeric { " class=\"n\"" } else { "" },
                    escape(cell)
                );
            }
            self.body.push_str("</tr>\n");
        }
        self.body.push_str("</table>\n");
        self
    }

    /// A plot embedded as a PNG `data:` URI, with its caption.
    pub fn image(&mut self, caption: &str, img: &RgbImage) -> Result<&mut Page, PlotError> {
        let mut png = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .map_err(|e| PlotError::Draw(format!("cannot encode the PNG: {e}")))?;
        Ok(self.png(caption, &png))
    }

    /// PNG bytes embedded as a `data:` URI, with its caption.
    pub fn png(&mut self, caption: &str, png: &[u8]) -> &mut Page {
        let data = base64::engine::general_purpose::STANDARD.encode(png);
        let _ = writeln!(
            self.body,
            "<figure><img alt=\"{}\" src=\"data:image/png;base64,{data}\"><figcaption>{}</figcaption></figure>",
            escape(caption),
            escape(caption)
        );
        self
    }

    /// The whole document.
    pub fn finish(&self) -> String {
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n{}</body>\n</html>\n",
            escape(&self.title),
            self.body
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_escaped_and_plots_are_embedded_with_nothing_fetched() {
        let mut p = Page::new("Report <of> \"unit\" & co");
        p.verdict(false, "FAIL: <script>")
            .table(&["a", "b"], &[vec!["1.5", "x<y"]]);
        p.image("plot", &RgbImage::new(4, 3)).expect("png");
        let html = p.finish();
        assert!(html.contains("<title>Report &lt;of&gt; &quot;unit&quot; &amp; co</title>"));
        assert!(html.contains("FAIL: &lt;script&gt;"));
        assert!(!html.contains("<script>"));
        assert!(html.contains("<td class=\"n\">1.5</td><td>x&lt;y</td>"));
        assert!(html.contains("src=\"data:image/png;base64,iVBORw0KGgo"));
        assert!(!html.contains("http://") && !html.contains("https://"));
    }
}
