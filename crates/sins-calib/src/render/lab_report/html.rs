//! `report.html` of a report directory: the report's Markdown rendered as one self-contained
//! HTML file. Every image is the report's own PNG embedded as a `data:` URI, the style sheet is
//! inline, and there is no script and no reference to anything outside the file, so it opens
//! the same from a mail attachment, an archive or a machine without network. Raw HTML in the
//! Markdown (a unit's name, a command line) is shown as text, never interpreted.

use crate::Error;
use pulldown_cmark::{CowStr, Event, Options, Parser, Tag};
use std::path::Path;

/// The style of the page: readable tables and images no wider than the page.
const STYLE: &str = "body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;\
line-height:1.4;color:#222}table{border-collapse:collapse;margin:0.5em 0 1em}\
th,td{border:1px solid #bbb;padding:0.2em 0.5em;vertical-align:top}th{background:#eee}\
td{font-variant-numeric:tabular-nums}img{max-width:100%;height:auto}\
pre{background:#f6f6f6;padding:0.6em;overflow-x:auto;font-size:90%}\
code{font-size:95%}h2{border-bottom:1px solid #ccc;padding-bottom:0.2em;margin-top:1.6em}";

/// Base64 (RFC 4648, with padding) of `bytes`.
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for (k, shift) in [18, 12, 6, 0].into_iter().enumerate() {
            if k <= chunk.len() {
                out.push(char::from(ALPHABET[((n >> shift) & 63) as usize]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The image `name` of the report directory `dir` as a `data:` URI. Only the report's own
/// PNG files are embedded: any other reference is an error of this program.
fn data_uri(dir: &Path, name: &str) -> Result<String, Error> {
    let own = name.ends_with(".png") && !name.contains(['/', '\\', ':']) && !name.starts_with('.');
    if !own {
        return Err(format!(
            "report.html: the image `{name}` is not one of the report's own PNG files"
        )
        .into());
    }
    let path = dir.join(name);
    let bytes =
        std::fs::read(&path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    Ok(format!("data:image/png;base64,{}", base64(&bytes)))
}

/// Escape text for HTML.
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
    out
}

/// The report's Markdown `md` as one HTML page titled `title`, the images it shows (PNG files
/// in `dir`) embedded.
pub fn html_of(md: &str, title: &str, dir: &Path) -> Result<String, Error> {
    let mut events = Vec::new();
    for event in Parser::new_ext(md, Options::ENABLE_TABLES) {
        events.push(match event {
            // Raw HTML in the text (a name, a path): shown as written.
            Event::Html(h) | Event::InlineHtml(h) => Event::Text(h),
            Event::Start(Tag::Image {
                link_type,
                dest_url,
                title,
                id,
            }) => Event::Start(Tag::Image {
                link_type,
                dest_url: CowStr::from(data_uri(dir, &dest_url)?),
                title,
                id,
            }),
            e => e,
        });
    }
    let mut body = String::new();
    pulldown_cmark::html::push_html(&mut body, events.into_iter());
    Ok(format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta \
         name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>{}</title>\n\
         <style>{STYLE}</style>\n</head>\n<body>\n{body}</body>\n</html>\n",
        escape(title)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_of_rfc_4648_vectors() {
        for (raw, enc) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(raw.as_bytes()), enc);
        }
    }

    #[test]
    fn raw_html_is_text_and_images_are_embedded() {
        let dir = std::env::temp_dir().join(format!("sins-calib-html-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a.png"), [137u8, 80, 78, 71]).unwrap();
        let md = "# T\n\n| a | b |\n|---|---|\n| <script>x</script> | 1 |\n\n![plot](a.png)\n";
        let html = html_of(md, "T <1>", &dir).unwrap();
        assert!(html.contains("&lt;script&gt;"), "{html}");
        assert!(!html.contains("<script"), "{html}");
        assert!(
            html.contains("<img src=\"data:image/png;base64,iVBORw==\""),
            "{html}"
        );
        assert!(html.contains("<title>T &lt;1&gt;</title>"));
        assert!(html.contains("<table>"));
        assert!(html_of("![x](http://example.org/a.png)", "T", &dir).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
