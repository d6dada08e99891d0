//! The HTML page: layout, styles, the error-catching prelude and the inlined pictures.

use base64::Engine as _;
use std::fmt::Write as _;

use super::{viewer, Figure, Legend, Picture, Report, Section};
use crate::error::Result;
use crate::picture::{self as raster, Rgb};

/// No network at all: only inline scripts/styles and `data:` URLs.
const CSP: &str = "default-src 'none'; script-src 'unsafe-inline' data:; \
                   style-src 'unsafe-inline'; img-src data:";

const STYLE: &str = r#"
body{margin:0;font:14px/1.4 system-ui,sans-serif;background:#f4f4f2;color:#222}
header{padding:10px 20px;background:#323844;color:#eee;height:44px;box-sizing:border-box}
header h1{display:inline;font-size:18px;margin:0 12px 0 0}header span{color:#aaa}
main{padding:0 20px 40px}h2{font-size:16px;margin:22px 0 8px}
#ps-viewer{position:relative;width:100%;height:560px;background:#1b1e24;color:#eee}
#ps-viewer canvas{display:block}
.tools{margin:6px 0;color:#555}.tools button{margin-right:10px}
.strip{display:flex;gap:6px;overflow-x:auto;padding-bottom:6px}
.strip figure{margin:0}.strip img{height:96px;image-rendering:auto}
.grid{display:flex;flex-wrap:wrap;gap:16px}
.grid figure{margin:0}.grid img{width:300px;border:1px solid #ccc;image-rendering:pixelated}
.grid img.plot{width:auto;max-width:820px;image-rendering:auto}
figcaption{font-size:12px;color:#444}
.legend{display:flex;align-items:center;gap:6px;font-size:11px;color:#444}
.legend img{height:10px;width:160px;border:0}
table{border-collapse:collapse}td{padding:3px 12px 3px 0;border-bottom:1px solid #ddd}
td:first-child{color:#555}#ps-errors{color:#b00}
.tools button{margin-right:4px}svg.polar{border:1px solid #ccc}
#ps-warnings{margin:14px 0 0;padding:10px 14px;background:#fff3cd;border:2px solid #d9a400;color:#5c4300}
#ps-warnings p{margin:4px 0}#ps-warnings b{color:#8a3b00}
"#;

/// Installed first: counts script errors into `<html data-errors>` and `#ps-errors`.
const PRELUDE_JS: &str = r#"(function(){
var root=document.documentElement;root.dataset.errors='0';root.dataset.viewer='loading';
function note(m){root.dataset.errors=String(Number(root.dataset.errors)+1);
var e=document.getElementById('ps-errors');if(e){e.textContent+=m+'\n';}}
window.addEventListener('error',function(ev){note('error: '+(ev.message||ev.type));},true);
window.addEventListener('unhandledrejection',function(ev){note('unhandled rejection: '+ev.reason);});
document.addEventListener('securitypolicyviolation',function(ev){note('CSP: '+ev.blockedURI);});
var ce=console.error;console.error=function(){note('console.error: '+Array.prototype.join.call(arguments,' '));
return ce.apply(console,arguments);};})();"#;

/// HTML-escape text.
pub(crate) fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
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

fn data_uri(png: &[u8]) -> String {
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(png)
    )
}

fn rgb_uri(rgb: &Rgb) -> Result<String> {
    Ok(data_uri(&raster::encode_png(rgb)?))
}

/// The whole page.
pub(crate) fn page(r: &Report) -> Result<String> {
    let mut s = String::with_capacity(2 << 20);
    s.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    let _ = writeln!(
        s,
        "<meta http-equiv=\"Content-Security-Policy\" content=\"{CSP}\">"
    );
    s.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
    s.push_str("<link rel=\"icon\" href=\"data:,\">\n");
    let _ = writeln!(s, "<title>{} — photostereo report</title>", esc(&r.title));
    let _ = writeln!(s, "<script>{PRELUDE_JS}</script>\n<style>{STYLE}</style>");
    if r.mesh.is_some() {
        let _ = writeln!(
            s,
            "<script type=\"importmap\">{}</script>",
            viewer::import_map()
        );
    }
    s.push_str("</head>\n<body>\n");
    let _ = writeln!(
        s,
        "<header><h1>{}</h1><span>{}</span></header>\n<main>",
        esc(&r.title),
        esc(&r.subtitle)
    );
    s.push_str("<pre id=\"ps-errors\"></pre>\n");
    warnings_section(&mut s, r);
    viewer_section(&mut s, r);
    relight_section(&mut s, r);
    inputs_section(&mut s, r)?;
    for (section, title) in [
        (Section::Maps, "Maps"),
        (Section::Errors, "Errors against ground truth"),
        (Section::Interreflections, "Interreflection removal"),
        (Section::Lights, "Lights"),
    ] {
        figures_section(&mut s, r, section, title)?;
    }
    table_section(&mut s, r);
    s.push_str("</main>\n");
    if let Some(mesh) = &r.mesh {
        // JSON holds only base64, digits and punctuation: nothing that could close the tag.
        let _ = writeln!(
            s,
            "<script type=\"application/json\" id=\"ps-mesh\">{}</script>",
            mesh.payload_json()
        );
        let _ = writeln!(s, "<script type=\"module\">{}</script>", viewer::VIEWER_JS);
    } else {
        s.push_str("<script>document.documentElement.dataset.viewer='none';</script>\n");
    }
    match &r.relight {
        Some(maps) => {
            // base64, digits and punctuation only: nothing that could close the tag
            let _ = writeln!(
                s,
                "<script type=\"application/json\" id=\"ps-relight-data\">{}</script>",
                maps.payload_json()
            );
            let _ = writeln!(s, "<script>{}</script>", super::relight::RELIGHT_JS);
        }
        None => s.push_str("<script>document.documentElement.dataset.relight='none';</script>\n"),
    }
    s.push_str("</body>\n</html>\n");
    Ok(s)
}

/// Warnings first, in a box no reader can miss.
fn warnings_section(s: &mut String, r: &Report) {
    if r.warnings.is_empty() {
        return;
    }
    s.push_str("<div id=\"ps-warnings\" role=\"alert\">");
    for w in &r.warnings {
        let _ = write!(s, "<p><b>Warning:</b> {}</p>", esc(w));
    }
    s.push_str("</div>\n");
}

fn relight_section(s: &mut String, r: &Report) {
    let Some(maps) = &r.relight else { return };
    let _ = writeln!(
        s,
        "<h2 id=\"relight\">Relighting</h2>\n<canvas id=\"ps-relight\" \
         style=\"height:min(78vh,{}px);max-width:100%;cursor:crosshair;background:#1b1e24\"></canvas>\n\
         <div class=\"tools\">press and drag over the picture to move the light (centre: \
         from the camera; edge: grazing) · Lambertian shading of the normals and albedo, \
         {}×{} px</div>",
        (2 * maps.height).max(256),
        maps.width,
        maps.height
    );
}

fn viewer_section(s: &mut String, r: &Report) {
    let Some(mesh) = &r.mesh else { return };
    s.push_str("<h2>3-D view</h2>\n<div id=\"ps-viewer\"></div>\n");
    let _ = writeln!(
        s,
        "<div class=\"tools\"><button id=\"ps-reset\">reset view</button>\
         <button id=\"ps-front\">front</button><button id=\"ps-side\">side</button>\
         <button id=\"ps-top\">top</button> \
         <label><input type=\"checkbox\" id=\"ps-albedo\" checked> albedo colours</label> \
         &nbsp; drag: rotate · wheel: zoom · right-drag: pan · {} triangles{}</div>",
        mesh.triangles(),
        if mesh.stride > 1 {
            format!(
                " (decimated for the page: one vertex every {} rows and columns)",
                mesh.stride
            )
        } else {
            String::new()
        }
    );
}

fn inputs_section(s: &mut String, r: &Report) -> Result<()> {
    if r.inputs.is_empty() {
        return Ok(());
    }
    let _ = writeln!(
        s,
        "<h2>Input images ({})</h2>\n<div class=\"strip\">",
        r.inputs.len()
    );
    for (name, thumb) in &r.inputs {
        let _ = writeln!(
            s,
            "<figure><img src=\"{}\" alt=\"{n}\"><figcaption>{n}</figcaption></figure>",
            rgb_uri(thumb)?,
            n = esc(name)
        );
    }
    s.push_str("</div>\n");
    Ok(())
}

fn figures_section(s: &mut String, r: &Report, section: Section, title: &str) -> Result<()> {
    let figs: Vec<&Figure> = r.figures.iter().filter(|f| f.section == section).collect();
    if figs.is_empty() {
        return Ok(());
    }
    let _ = writeln!(s, "<h2>{}</h2>\n<div class=\"grid\">", esc(title));
    for f in figs {
        let c = esc(&f.caption);
        let (uri, class) = match &f.picture {
            Picture::Raster(rgb) => (rgb_uri(rgb)?, "map"),
            Picture::Png(bytes) => (data_uri(bytes), "plot"),
            Picture::Svg(svg) => {
                let _ = writeln!(s, "<figure>{svg}<figcaption>{c}</figcaption></figure>");
                continue;
            }
        };
        let _ = write!(
            s,
            "<figure><img class=\"{class}\" src=\"{uri}\" alt=\"{c}\"><figcaption>{c}</figcaption>"
        );
        if let Some(legend) = &f.legend {
            legend_html(s, legend)?;
        }
        s.push_str("</figure>\n");
    }
    s.push_str("</div>\n");
    Ok(())
}

fn legend_html(s: &mut String, l: &Legend) -> Result<()> {
    let bar = rgb_uri(&raster::colorbar(l.cmap, 160, 1))?;
    let _ = write!(
        s,
        "<div class=\"legend\"><span>{}</span><img src=\"{bar}\" alt=\"colour bar\"><span>{}</span></div>",
        esc(&l.lo),
        esc(&l.hi)
    );
    Ok(())
}

fn table_section(s: &mut String, r: &Report) {
    if r.table.is_empty() {
        return;
    }
    s.push_str("<h2>Figures</h2>\n<table id=\"ps-figures\">\n");
    for (k, v) in &r.table {
        let _ = writeln!(s, "<tr><td>{}</td><td>{}</td></tr>", esc(k), esc(v));
    }
    s.push_str("</table>\n");
}

#[cfg(test)]
mod tests {
    use super::esc;

    #[test]
    fn escapes_markup() {
        assert_eq!(
            esc("<a href='x'>&</a>"),
            "&lt;a href=&#39;x&#39;&gt;&amp;&lt;/a&gt;"
        );
    }
}
