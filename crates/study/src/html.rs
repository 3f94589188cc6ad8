//! A self-contained HTML report: headings, paragraphs, tables and figures inlined as data URIs.
//!
//! No network, no external files: PNG figures are embedded as base64 `data:` URIs so the page
//! renders the same when mailed around. Every string is HTML-escaped.

use std::fmt::Write as _;

/// One block of the report, in reading order.
#[derive(Debug, Clone)]
pub enum Block {
    /// A section heading (`<h2>`): starts a collapsible section (`<details>`) that runs to the
    /// next heading, listed in the table of contents.
    Heading(String),
    /// A section heading like [`Block::Heading`] whose section is open when the page opens.
    HeadingOpen(String),
    /// A subsection heading (`<h3>`): a collapsible subsection inside the current section,
    /// listed in the table of contents under it.
    SubHeading(String),
    /// A paragraph of plain text.
    Paragraph(String),
    /// A bullet list.
    List(Vec<String>),
    /// A table.
    Table(Table),
    /// Trusted HTML written by this crate (inline SVG sketches); never user text.
    Raw(String),
    /// A PNG figure shown at full page width (at least 800 px on a normal screen).
    Wide {
        /// Caption under the figure.
        caption: String,
        /// PNG bytes.
        png: Vec<u8>,
    },
    /// A PNG figure with a caption.
    Figure {
        /// Caption under the figure.
        caption: String,
        /// PNG bytes.
        png: Vec<u8>,
    },
    /// A verdict box: one question, its short answer and the lines behind it.
    Verdict(Verdict),
    /// The table of contents of every heading and subheading of the report, placed here.
    Toc,
}

/// How a verdict reads at a glance (the box's colour).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// The target is met (green).
    Pass,
    /// The target is missed somewhere (red).
    Fail,
    /// An answer without pass or fail (grey).
    Info,
}

/// A verdict box.
#[derive(Debug, Clone)]
pub struct Verdict {
    /// The question, e.g. "Is σ < 5 mm reached?".
    pub question: String,
    /// The short answer (one sentence).
    pub answer: String,
    /// The lines behind the answer (one per layout, …).
    pub lines: Vec<String>,
    /// Pass, fail or information.
    pub status: Status,
}

/// A table with a caption, a header row and body rows (all plain text).
#[derive(Debug, Clone, Default)]
pub struct Table {
    /// Caption above the table.
    pub caption: String,
    /// Header cells.
    pub header: Vec<String>,
    /// Body rows.
    pub rows: Vec<Vec<String>>,
}

/// The report: a title and blocks.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// Page title and `<h1>`.
    pub title: String,
    /// Content in reading order.
    pub blocks: Vec<Block>,
}

/// The anchor of the `k`-th heading (section or subsection, counted together).
fn anchor(k: usize) -> String {
    format!("sec{k}")
}

impl Report {
    /// Appends a block.
    pub fn push(&mut self, b: Block) {
        self.blocks.push(b);
    }

    /// The table of contents: one link per heading, subheadings nested under their section.
    fn toc(&self) -> String {
        let mut s =
            String::from("<nav class=\"toc\" id=\"toc\"><p class=\"gcap\">Contents</p><ol>\n");
        let (mut k, mut in_sub) = (0usize, false);
        for b in &self.blocks {
            let (text, sub) = match b {
                Block::Heading(h) | Block::HeadingOpen(h) => (h, false),
                Block::SubHeading(h) => (h, true),
                _ => continue,
            };
            if sub && !in_sub {
                s.push_str("<ol>\n");
            } else if !sub && in_sub {
                s.push_str("</ol>\n");
            }
            in_sub = sub;
            k += 1;
            let _ = writeln!(
                s,
                "<li><a href=\"#{}\">{}</a></li>",
                anchor(k),
                escape(text)
            );
        }
        if in_sub {
            s.push_str("</ol>\n");
        }
        s.push_str("</ol></nav>\n");
        s
    }

    /// Renders the whole page: every section a `<details>` (collapsed; the table of contents
    /// and the URL fragment `#all` open them), the verdicts and the contents on top.
    pub fn to_html(&self) -> String {
        let mut s = String::new();
        let _ = write!(
            s,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'\">\n<title>{}</title>\n<style>{}</style>\n</head>\n<body>\n<h1>{}</h1>\n",
            escape(&self.title),
            CSS,
            escape(&self.title)
        );
        let mut st = RenderState::default();
        for b in &self.blocks {
            match b {
                Block::Heading(h) => st.open(&mut s, h, false, false),
                Block::HeadingOpen(h) => st.open(&mut s, h, false, true),
                Block::SubHeading(h) => st.open(&mut s, h, true, false),
                Block::Toc => s.push_str(&self.toc()),
                other => render_block(&mut s, other, &mut st.wide),
            }
        }
        st.close(&mut s, false);
        s.push_str(CHECK_SCRIPT);
        s.push_str("</body>\n</html>\n");
        s
    }
}

/// Which `<details>` are open while rendering, and the count of wide figures (zoom anchors).
#[derive(Default)]
struct RenderState {
    headings: usize,
    section: bool,
    subsection: bool,
    wide: usize,
}

impl RenderState {
    /// Closes the open subsection (and, unless `keep_section`, the open section).
    fn close(&mut self, s: &mut String, keep_section: bool) {
        if self.subsection {
            s.push_str("</details>\n");
            self.subsection = false;
        }
        if self.section && !keep_section {
            s.push_str("</details>\n");
            self.section = false;
        }
    }

    /// Opens a section (`sub` = false) or a subsection, `open` on arrival or collapsed.
    fn open(&mut self, s: &mut String, title: &str, sub: bool, open: bool) {
        self.close(s, sub);
        self.headings += 1;
        let (class, tag) = if sub { ("sub", "h3") } else { ("sec", "h2") };
        let _ = writeln!(
            s,
            "<details class=\"{class}\" id=\"{}\"{}><summary><{tag}>{}</{tag}></summary>",
            anchor(self.headings),
            if open { " open" } else { "" },
            escape(title)
        );
        if sub {
            self.subsection = true;
        } else {
            self.section = true;
        }
    }
}

/// Renders one content block (not a heading nor the table of contents).
fn render_block(s: &mut String, b: &Block, wide: &mut usize) {
    match b {
        Block::Heading(_) | Block::HeadingOpen(_) | Block::SubHeading(_) | Block::Toc => {}
        Block::Paragraph(p) => {
            let _ = writeln!(s, "<p>{}</p>", escape(p));
        }
        Block::List(items) => {
            s.push_str("<ul>\n");
            for i in items {
                let _ = writeln!(s, "<li>{}</li>", escape(i));
            }
            s.push_str("</ul>\n");
        }
        Block::Table(t) => render_table(s, t),
        Block::Raw(h) => {
            s.push_str(h);
            s.push('\n');
        }
        Block::Wide { caption, png } => {
            // Shown at the page width (≥ the figure's natural width on a 1400 px screen), so
            // the image is embedded once: no enlarged copy.
            *wide += 1;
            let _ = writeln!(
                s,
                "<figure class=\"wide\" id=\"fig{wide}\"><img alt=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption></figure>",
                escape(caption),
                base64(png),
                escape(caption)
            );
        }
        Block::Figure { caption, png } => {
            let _ = writeln!(
                s,
                "<figure><img alt=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption></figure>",
                escape(caption),
                base64(png),
                escape(caption)
            );
        }
        Block::Verdict(v) => render_verdict(s, v),
    }
}

fn render_table(s: &mut String, t: &Table) {
    let _ = writeln!(s, "<table>\n<caption>{}</caption>", escape(&t.caption));
    s.push_str("<thead><tr>");
    for h in &t.header {
        let _ = write!(s, "<th>{}</th>", escape(h));
    }
    s.push_str("</tr></thead>\n<tbody>\n");
    for r in &t.rows {
        s.push_str("<tr>");
        for c in r {
            let _ = write!(s, "<td>{}</td>", escape(c));
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</tbody>\n</table>\n");
}

fn render_verdict(s: &mut String, v: &Verdict) {
    let class = match v.status {
        Status::Pass => "pass",
        Status::Fail => "fail",
        Status::Info => "info",
    };
    let _ = write!(
        s,
        "<div class=\"verdict {class}\"><p class=\"q\">{}</p><p class=\"a\">{}</p>",
        escape(&v.question),
        escape(&v.answer)
    );
    if !v.lines.is_empty() {
        s.push_str("<ul>");
        for l in &v.lines {
            let _ = write!(s, "<li>{}</li>", escape(l));
        }
        s.push_str("</ul>");
    }
    s.push_str("</div>\n");
}

const CSS: &str = "body{font-family:sans-serif;font-size:16px;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}\
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}\
th{background:#eee}caption{font-weight:bold;text-align:left;padding:.3em 0}\
figure{margin:1.5em 0}img{max-width:100%;border:1px solid #ddd}figcaption{font-size:.9em;color:#555}\
.gallery{display:flex;flex-wrap:wrap;gap:1%}.gallery figure{width:32%;margin:.5em 0}.gcap{width:100%;font-weight:bold;margin:.5em 0 0}\
figure.wide img{width:100%}\
td.l{text-align:left}.note{background:#fff8e0;border-left:4px solid #e0b000;padding:.4em .8em}\
details.sec{border-top:1px solid #ccc;margin:.4em 0}details.sub{margin:.3em 0 .3em 1em}\
summary{cursor:pointer}summary h2,summary h3{display:inline;margin:.3em 0}summary h2{font-size:1.4em}summary h3{font-size:1.15em}\
.verdicts{display:flex;flex-wrap:wrap;gap:1em;margin:1em 0}.verdict{flex:1 1 320px;border-radius:6px;padding:.5em 1em;border-left:8px solid #999;background:#f4f4f4}\
.verdict.pass{border-color:#2a2;background:#eef8ee}.verdict.fail{border-color:#d22;background:#fdeeee}\
.verdict .q{font-weight:bold;margin:.3em 0}.verdict .a{font-size:1.1em;margin:.3em 0}.verdict ul{margin:.3em 0;padding-left:1.2em}\
.toc{background:#f8f8f8;border:1px solid #ddd;padding:.3em 1em;margin:1em 0}.toc ol{margin:.2em 0}\
.meta{color:#444}\
table.answer{font-size:.85em;margin:.5em 0 1em;width:100%}table.answer td[data-key=\"hot_spot.point_mm\"]{white-space:nowrap}table.answer caption{font-weight:normal}table.answer td,table.answer th{text-align:left;vertical-align:top;overflow-wrap:break-word;padding:.2em .4em}table.answer td[data-key=name]{overflow-wrap:anywhere}\
@media (max-width:1000px){table.answer{font-size:.75em}table.answer td[data-key=\"hot_spot.point_mm\"]{white-space:normal}}\
table.answer tr.fail td[data-key=reached]{color:#b00;font-weight:bold}table.answer tr.pass td[data-key=reached]{color:#070;font-weight:bold}";

/// Marks `<body data-images="ok:N">` once every image decoded, or `"broken:K/N"`;
/// `data-wide-min-px` = the natural width of the narrowest full-width figure (−1: none),
/// `data-wide-min-shown-px` its smallest rendered width among the visible ones, `data-load-ms`
/// the time from navigation to the load event,
/// `data-min-font-px` = the smallest rendered text size on the page (inline SVG text scaled by
/// its drawing), `data-toc` = links of the table of contents / collapsible sections; read by
/// `cargo xtask report-check` and the browser test through headless Chromium. It runs locally
/// and loads nothing. A link of the table of contents (or the fragment `#all`) opens its
/// section.
const CHECK_SCRIPT: &str = "<script>(function(){\
function openTo(h){if(h==='#all'){document.querySelectorAll('details').forEach(function(d){d.open=true;});return;}\
var e=h&&document.getElementById(h.slice(1));while(e){if(e.tagName==='DETAILS'){e.open=true;}e=e.parentElement;}}\
window.addEventListener('hashchange',function(){openTo(location.hash);});openTo(location.hash);\
window.addEventListener('load',function(){var i=document.images,b=0;\
for(var k=0;k<i.length;k++){if(!i[k].complete||i[k].naturalWidth===0){b++;}}\
document.body.setAttribute('data-images',b===0?'ok:'+i.length:'broken:'+b+'/'+i.length);\
var w=document.querySelectorAll('figure.wide img'),m=-1,q=-1;for(var k=0;k<w.length;k++){var c=w[k].naturalWidth,d=w[k].getBoundingClientRect().width;if(m<0||c<m){m=c;}if(d>0&&(q<0||d<q)){q=d;}}\
document.body.setAttribute('data-wide-min-px',String(Math.round(m)));document.body.setAttribute('data-wide-min-shown-px',String(Math.round(q)));\
document.body.setAttribute('data-load-ms',String(Math.round(performance.now())));\
var f=1e9,all=document.body.querySelectorAll('*');for(var k=0;k<all.length;k++){var el=all[k],t=false;\
for(var n=el.firstChild;n;n=n.nextSibling){if(n.nodeType===3&&n.textContent.trim()){t=true;break;}}\
if(!t||el.getClientRects().length===0||el.closest('script,style')){continue;}\
var px=parseFloat(getComputedStyle(el).fontSize),svg=el.closest('svg');\
if(svg){var vb=svg.viewBox&&svg.viewBox.baseVal,r=svg.getBoundingClientRect();if(vb&&vb.width>0){px*=r.width/vb.width;}}\
if(px<f){f=px;}}document.body.setAttribute('data-min-font-px',f<1e9?f.toFixed(1):'-1');\
document.body.setAttribute('data-toc',document.querySelectorAll('.toc a').length+'/'+document.querySelectorAll('details').length);\
var an=document.getElementById('answer');if(an){var ar=an.getBoundingClientRect();document.body.setAttribute('data-answer-px',Math.round(ar.top+window.scrollY)+','+Math.round(ar.bottom+window.scrollY));}});})();</script>\n";

/// Escapes text for HTML element content and attribute values.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            _ => o.push(c),
        }
    }
    o
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut o = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        o.push(A[(n >> 18) as usize & 63] as char);
        o.push(A[(n >> 12) as usize & 63] as char);
        o.push(if chunk.len() > 1 {
            A[(n >> 6) as usize & 63] as char
        } else {
            '='
        });
        o.push(if chunk.len() > 2 {
            A[n as usize & 63] as char
        } else {
            '='
        });
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_rfc4648_vectors() {
        // RFC 4648 §10 test vectors.
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (i, o) in cases {
            assert_eq!(base64(i.as_bytes()), o, "input {i:?}");
        }
    }

    #[test]
    fn escape_nominal() {
        assert_eq!(
            escape(r#"<a href="x">&'"#),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
        );
    }

    #[test]
    fn report_renders_every_block() {
        let mut r = Report {
            title: "T <1>".into(),
            ..Default::default()
        };
        r.push(Block::Toc);
        r.push(Block::Heading("H".into()));
        r.push(Block::Paragraph("p & q".into()));
        r.push(Block::List(vec!["a".into()]));
        r.push(Block::Table(Table {
            caption: "c".into(),
            header: vec!["x".into()],
            rows: vec![vec!["1".into()]],
        }));
        r.push(Block::Figure {
            caption: "f".into(),
            png: vec![1, 2, 3],
        });
        let h = r.to_html();
        assert!(h.contains("<title>T &lt;1&gt;</title>"));
        assert!(h.contains("<p>p &amp; q</p>"));
        assert!(h.contains("<td>1</td>"));
        assert!(h.contains("data:image/png;base64,AQID"));
        assert!(h.trim_end().ends_with("</html>"));
        assert!(h.contains("<a href=\"#sec1\">H</a>"));
        assert!(h.contains("<details class=\"sec\" id=\"sec1\"><summary><h2>H</h2></summary>"));
    }

    /// Sections and subsections nest: every `<details>` is closed, the table of contents nests
    /// the subsections under their section, and the anchors follow the headings in order.
    #[test]
    fn sections_nest_and_the_contents_link_every_heading() {
        let mut r = Report::default();
        r.push(Block::Verdict(Verdict {
            question: "Q?".into(),
            answer: "yes".into(),
            lines: vec!["l1".into()],
            status: Status::Pass,
        }));
        r.push(Block::Toc);
        r.push(Block::Heading("A".into()));
        r.push(Block::SubHeading("A1".into()));
        r.push(Block::Paragraph("x".into()));
        r.push(Block::SubHeading("A2".into()));
        r.push(Block::Heading("B".into()));
        let h = r.to_html();
        assert_eq!(h.matches("<details").count(), 4);
        assert_eq!(h.matches("</details>").count(), 4);
        let toc = &h[h.find("<nav").unwrap()..h.find("</nav>").unwrap()];
        assert_eq!(
            toc,
            "<nav class=\"toc\" id=\"toc\"><p class=\"gcap\">Contents</p><ol>\n<li><a href=\"#sec1\">A</a></li>\n<ol>\n<li><a href=\"#sec2\">A1</a></li>\n<li><a href=\"#sec3\">A2</a></li>\n</ol>\n<li><a href=\"#sec4\">B</a></li>\n</ol>"
        );
        // A2 closes A1 but not A; B closes A2 and A.
        let a2 = h.find("id=\"sec3\"").unwrap();
        let b = h.find("id=\"sec4\"").unwrap();
        assert_eq!(h[..a2].matches("</details>").count(), 1);
        assert_eq!(h[a2..b].matches("</details>").count(), 2);
        assert!(h.contains("<div class=\"verdict pass\"><p class=\"q\">Q?</p>"));
    }
}
