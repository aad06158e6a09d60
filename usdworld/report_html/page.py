"""The report page: one self-contained HTML file (images as data URIs, inline CSS, JS and SVG).

A Content-Security-Policy meta tag allows nothing but inline styles, inline scripts and
``data:`` images, so the page can reach no network even if a value slipped through. Every
value taken from the world is HTML-escaped.

Sections: images (photo, render, overlay, and a wipe between photo and render), camera,
objects (a table sorted by clicking its headers), plots, evaluation, inputs and warnings.
"""

from __future__ import annotations

import base64
import json
import math
import re
from collections.abc import Mapping, Sequence
from html import escape
from typing import Any

from usdworld.io.label_table import label_table
from usdworld.render.classes import label_id_for_class
from usdworld.report_html.collect import PageInputs
from usdworld.report_html.svg import depth_cue_plot, plan_view

CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'"

STYLE = """
body{font:14px/1.4 system-ui,sans-serif;margin:1.5em;color:#222}
h1{font-size:1.4em;margin-bottom:.2em} h2{font-size:1.15em;margin-top:1.6em;border-bottom:1px solid #ccc}
.sub{color:#666} .note{color:#8a5a00} .warn{color:#a00000}
.images{display:flex;gap:8px;flex-wrap:wrap} .images figure{margin:0;flex:1 1 300px;min-width:0}
.images img{width:100%;display:block} figcaption{color:#555;font-size:.9em}
.wipe{position:relative;max-width:1024px;margin-top:8px} .wipe img{width:100%;display:block}
.wipe img.top{position:absolute;left:0;top:0;clip-path:inset(0 0 0 50%)}
.wipe input{width:100%}
table{border-collapse:collapse;font-size:12.5px} td,th{border:1px solid #ddd;padding:2px 5px;vertical-align:top}
th{background:#f3f3f3} td.n{text-align:right;font-variant-numeric:tabular-nums}
#objects th{cursor:pointer;user-select:none;white-space:nowrap} #objects td{white-space:nowrap}
#objects td:last-child{white-space:normal;min-width:12em} .scroll{overflow-x:auto;max-width:100%}
#objects th[aria-sort=ascending]::after{content:" \\25B2"} #objects th[aria-sort=descending]::after{content:" \\25BC"}
tr.deleted td{color:#999;text-decoration:line-through} tr.moved td:first-child::after{content:" (moved)";color:#a06000}
.plot text{font-size:11px;fill:#333} .plot .grid{stroke:#e4e4e4} .plot .bar{stroke-width:2}
.plot .fused{stroke:#000;stroke-width:2} .plot .fov{fill:#ffe9a8;fill-opacity:.5;stroke:#d9b44a}
.plot .footprint{stroke:#333;stroke-width:.6;fill-opacity:.85} .plot .camera{fill:#d00}
.plot .scalebar{stroke:#000;stroke-width:2}
.plots{display:flex;gap:24px;flex-wrap:wrap;align-items:flex-start}
"""

SCRIPT = """
(function () {
  var r = document.getElementById('wipe-range'), top = document.getElementById('wipe-top');
  if (r && top) r.addEventListener('input', function () { top.style.clipPath = 'inset(0 0 0 ' + r.value + '%)'; });
  var table = document.getElementById('objects');
  if (!table) return;
  var heads = table.tHead.rows[0].cells;
  function key(cell) { var v = cell.getAttribute('data-sort'); return v === null ? cell.textContent : v; }
  Array.prototype.forEach.call(heads, function (th, col) {
    th.addEventListener('click', function () {
      var asc = th.getAttribute('aria-sort') !== 'ascending';
      Array.prototype.forEach.call(heads, function (h) { h.removeAttribute('aria-sort'); });
      th.setAttribute('aria-sort', asc ? 'ascending' : 'descending');
      var body = table.tBodies[0], rows = Array.prototype.slice.call(body.rows);
      var numeric = th.getAttribute('data-type') === 'number';
      rows.sort(function (a, b) {
        var x = key(a.cells[col]), y = key(b.cells[col]), c;
        if (numeric) {
          x = x === '' ? NaN : Number(x); y = y === '' ? NaN : Number(y);
          c = isNaN(x) ? (isNaN(y) ? 0 : 1) : isNaN(y) ? -1 : (x - y) * (asc ? 1 : -1);
        } else { c = x.localeCompare(y) * (asc ? 1 : -1); }
        return c;
      });
      rows.forEach(function (row) { body.appendChild(row); });
    });
  });
})();
"""


def _f(x: Any, digits: int = 2, unit: str = "") -> str:
    """A number as text (``-`` when missing)."""
    if not isinstance(x, (int, float)) or isinstance(x, bool) or not math.isfinite(x):
        return "-"
    return f"{x:.{digits}f}{unit}"


def _data_uri(data: bytes, mime: str) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


def class_colours() -> dict[str, str]:
    """CSS colour of every class usdworld places: the Cityscapes colour of its label id."""
    by_id = {row.id: row.color for row in label_table()}
    names = {row.placed_as for row in label_table() if row.placed_as}
    return {
        n: "#{:02x}{:02x}{:02x}".format(*by_id[label_id_for_class(n)])
        for n in sorted(names)
        if label_id_for_class(n) in by_id
    }


def _images(inputs: PageInputs) -> str:
    im = inputs.images
    figures = []
    if im.photo is not None:
        figures.append(("photo", _data_uri(*im.photo), "the source photo"))
    if im.render is not None:
        figures.append(("render", _data_uri(im.render, "image/png"), "render from the source camera"))
    if im.overlay is not None:
        figures.append(("overlay", _data_uri(im.overlay, "image/png"), "rendered classes over the photo"))
    out = ['<h2 id="images">Photo, render, overlay</h2>']
    out += [f'<p class="note">{escape(n)}</p>' for n in im.notes]
    if not figures:
        out.append('<p class="note">Nothing to show.</p>')
        return "".join(out)
    out.append('<div class="images">')
    for role, uri, caption in figures:
        out.append(
            f'<figure><img id="img-{role}" src="{uri}" alt="{caption}"><figcaption>{caption}</figcaption></figure>'
        )
    out.append("</div>")
    if im.photo is not None and im.render is not None:
        out.append(
            '<h3>Wipe: photo (left) | render (right)</h3><div class="wipe">'
            f'<img id="wipe-bottom" src="{figures[0][1]}" alt="photo">'
            f'<img id="wipe-top" class="top" src="{figures[1][1]}" alt="render">'
            '<input id="wipe-range" type="range" min="0" max="100" value="50" aria-label="wipe position"></div>'
        )
    return "".join(out)


def _camera(report: Mapping[str, Any]) -> str:
    cam = report["camera"]
    K = cam.get("K") or [[None] * 3] * 3
    est = cam.get("estimated") or []
    rows = [
        (
            "image",
            f"{report.get('source_image', '')} ({'x'.join(str(v) for v in report.get('image_size', []))} px)",
        ),
        ("K (px)", "<br>".join("[" + ", ".join(_f(v, 2) for v in row) + "]" for row in K)),
        ("height", f"{_f(cam.get('height_m'))} m ± {_f(cam.get('sigma_height_m'))} m"),
        ("pitch", f"{_f(cam.get('pitch_deg'))}° ± {_f(cam.get('sigma_pitch_deg'))}°"),
        ("roll, yaw", f"{_f(cam.get('roll_deg'))}°, {_f(cam.get('yaw_deg'))}°"),
        ("estimated", escape(", ".join(est)) if est else "nothing: every camera parameter was given"),
        ("method", escape(str(cam.get("method", "")))),
    ]
    focal = cam.get("focal")
    if focal:
        cues = [
            f"{'used' if used else 'dropped'} {escape(str(c['source']))}: {_f(c.get('f_px'), 1)} px "
            f"(σ log {_f(c.get('sigma_log'), 3)}) {escape(str(c.get('detail') or ''))}"
            for used, group in ((True, focal.get("used", [])), (False, focal.get("dropped", [])))
            for c in group
        ]
        rows.append(
            (
                "focal estimate",
                f"{_f(focal.get('f_px'), 1)} px (σ log {_f(focal.get('sigma_log'), 3)})<br>"
                + "<br>".join(cues),
            )
        )
    dlt, depth = report.get("dlt") or {}, report.get("depth") or {}
    rows.append(
        (
            "ground homography",
            f"DLT from {escape(str(dlt.get('source', '')))}, RMS {_f(dlt.get('rms_px'))} px",
        )
    )
    rows.append(
        (
            "depth map",
            f"{escape(str(depth.get('source', '')))} ({escape(str(depth.get('kind', '')))}); alignment: {escape(str(depth.get('alignment', '')))}",
        )
    )
    body = "".join(f"<tr><th>{k}</th><td>{v}</td></tr>" for k, v in rows)
    return f'<h2 id="camera">Camera</h2><table id="camera-table">{body}</table>'


#: Object table columns: (header, numeric?).
COLUMNS = (
    ("name", False), ("class", False), ("variant", False), ("state", False),
    ("x m", True), ("y m", True), ("z m", True), ("yaw °", True), ("yaw source", False), ("yaw conf.", True),
    ("scale", True), ("size l×w×h m", False), ("fused depth m", True), ("depth method", False), ("depth cues (m ± σ)", False),
    ("contact", False), ("collision shift m", True), ("confidence", True), ("GT position error m", True), ("warnings", False),
)  # fmt: skip


def _cell(text: str, sort: Any = None, numeric: bool = False) -> str:
    attr = ""
    if sort is not None:
        attr = f' data-sort="{escape(str(sort))}"'
    elif numeric:
        attr = ' data-sort=""'
    return f"<td{' class=n' if numeric else ''}{attr}>{text}</td>"


def object_warnings(o: Mapping[str, Any], warnings: Sequence[str]) -> list[str]:
    """What to be wary of about one object: its own flags and the build warnings that name it."""
    out = []
    if o.get("bottom_truncated"):
        out.append("bottom cut by the image edge")
    if o.get("bottom_occluded"):
        out.append("ground contact occluded")
    name = re.compile(rf"\b{re.escape(str(o.get('name')))}\b")
    out += [w for w in warnings if name.search(w)]
    return out


def _num(x: Any) -> Any:
    return x if isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) else None


def _object_row(o: Mapping[str, Any], state: str, gt_error: float | None, warnings: Sequence[str]) -> str:
    pos = list(o.get("position_world") or [None] * 3)
    cues = []
    for k, c in sorted((o.get("depth_cues") or {}).items()):
        note = escape(str(c.get("note") or ""), quote=True)
        if _num(c.get("depth_m")) is not None:
            cues.append(
                f'<span title="{note}">{escape(k)} {_f(c.get("depth_m"))} ± {_f(c.get("sigma_m"))}</span>'
            )
        else:
            cues.append(f'<span class=sub title="{note}">{escape(k)} -</span>')
    contact = [f"({', '.join(_f(v, 0) for v in (o.get('contact_px') or []))}) px"]
    if o.get("standing_on"):
        contact.append(f"on {escape(str(o['standing_on']))}")
    if o.get("cut_sides"):
        contact.append("cut " + escape(",".join(o["cut_sides"])))
    shift = o.get("collision_displacement_m") or []
    shift_m = math.hypot(*shift) if shift and all(_num(v) is not None for v in shift) else None
    size = o.get("size_m") or []
    scale = _f(o.get("scale"), 3)
    if _num(o.get("scale_measured")) is not None and o.get("scale_measured") != o.get("scale"):
        scale += f" <span class=sub>(measured {_f(o.get('scale_measured'), 3)})</span>"
    warns = object_warnings(o, warnings)
    cells = [
        _cell(escape(str(o.get("name", "")))),
        _cell(escape(str(o.get("class", "")))),
        _cell(escape(str(o.get("variant") or ""))),
        _cell(state),
        *(_cell(_f(v), _num(v), True) for v in pos),
        _cell(_f(o.get("yaw_deg"), 1), _num(o.get("yaw_deg")), True),
        _cell(escape(str(o.get("yaw_source", "")))),
        _cell(_f(o.get("yaw_confidence")), _num(o.get("yaw_confidence")), True),
        _cell(scale, _num(o.get("scale")), True),
        _cell(" × ".join(_f(v, 1) for v in size)),
        _cell(_f(o.get("depth_m")), _num(o.get("depth_m")), True),
        _cell(escape(str(o.get("depth_method", "")))),
        _cell(" · ".join(cues)),
        _cell(" ".join(contact)),
        _cell(f"{_f(shift_m)} ({', '.join(_f(v) for v in shift)})" if shift else "-", shift_m, True),
        _cell(_f(o.get("confidence")), _num(o.get("confidence")), True),
        _cell(_f(gt_error), gt_error, True),
        _cell(
            f'<span class="warn">{"<br>".join(escape(w) for w in warns)}</span>' if warns else "", len(warns)
        ),
    ]
    return f'<tr class="{state}" data-name="{escape(str(o.get("name", "")))}">{"".join(cells)}</tr>'


def _objects(inputs: PageInputs) -> str:
    report = inputs.report
    gt_errors = {
        r["name"]: r["position_error_m"]
        for r in (inputs.evaluation or {}).get("object_rows", [])
        if r.get("placed") and r.get("name")
    }
    warnings = [str(w) for w in report.get("warnings", [])]
    head = "".join(
        f'<th data-type="{"number" if num else "text"}">{escape(name)}</th>' for name, num in COLUMNS
    )
    rows = [
        _object_row(o, inputs.states.get(o["name"], "built"), gt_errors.get(o["name"]), warnings)
        for o in report["objects"]
    ]
    for o in inputs.added:
        added = {**o, "depth_cues": {}}
        rows.append(_object_row(added, "added", gt_errors.get(o["name"]), warnings))
    counts = {s: sum(1 for v in inputs.states.values() if v == s) for s in ("moved", "deleted")}
    counts["added"] = len(inputs.added)
    edits = ", ".join(f"{n} {s}" for s, n in counts.items() if n)
    return (
        f'<h2 id="objects-heading">Objects ({len(rows)})</h2>'
        f'<p class="sub">As built (report.json){"; edits since: " + edits if edits else ""}. '
        "Click a header to sort; hover a depth cue for its note. Positions in the world frame: x forward, y left, z up, metres; "
        "collision shift is how far resolving overlaps moved the object.</p>"
        f'<div class="scroll"><table id="objects"><thead><tr>{head}</tr></thead><tbody>{"".join(rows)}</tbody></table></div>'
    )


def _plots(report: Mapping[str, Any]) -> str:
    objects = report["objects"]
    K = report["camera"].get("K")
    size = report.get("image_size") or []
    fov = None
    if K and len(size) == 2 and all(_num(v) is not None for v in (K[0][0], K[0][2])) and K[0][0] > 0:
        fov = (math.atan2(K[0][2], K[0][0]), math.atan2(size[0] - K[0][2], K[0][0]))
    return (
        '<h2 id="plots">Plots</h2><div class="plots">'
        f"<div><h3>Depth cues against the fused depth</h3>{depth_cue_plot(objects)}</div>"
        f"<div><h3>Plan view (as built)</h3>{plan_view(objects, class_colours(), fov)}</div></div>"
    )


def _evaluation(inputs: PageInputs) -> str:
    ev = inputs.evaluation
    out = ['<h2 id="evaluation">Evaluation</h2>']
    out += [f'<p class="note">{escape(n)}</p>' for n in inputs.evaluation_notes]
    if ev is None:
        return "".join(out)
    if ev.get("per_class_iou"):
        rows = "".join(
            f"<tr><td>{escape(k)}</td><td class=n>{_f(v, 3)}</td></tr>"
            for k, v in ev["per_class_iou"].items()
        )
        out.append(
            f'<p>Layout: mIoU <b id="miou">{_f(ev.get("miou"), 3)}</b> over {len(ev.get("classes", []))} classes the world places '
            f"(render {'x'.join(str(v) for v in ev.get('size', []))}).</p>"
            f'<table id="iou-table"><thead><tr><th>class</th><th>IoU</th></tr></thead><tbody>{rows}</tbody></table>'
        )
    if ev.get("ssim") is not None:
        out.append(f'<p>SSIM photo vs render: <b id="ssim">{_f(ev["ssim"], 3)}</b></p>')
    summary = ev.get("objects")
    if summary:
        gt = ev.get("ground_truth") or {}
        rows = "".join(
            f"<tr><td>{escape(name)}</td><td class=n>{s['placed']}/{s['total']}</td>"
            + "".join(
                f"<td class=n>{_f(s.get(k), d)}</td>"
                for k, d in (
                    ("median_position_error_m", 2),
                    ("median_depth_error_m", 2),
                    ("median_yaw_error_deg", 1),
                    ("median_size_error_m", 2),
                )
            )
            + "</tr>"
            for name, s in [*summary["per_class"].items(), ("things", summary["things"]), ("all", summary)]
        )
        how = "instance ids, then distance" if summary.get("matched_by_instance_id") else "distance"
        out.append(
            f"<h3>3D errors against {escape(str(gt.get('file', '')))} ({escape(str(gt.get('kind', '')))})</h3>"
            '<table id="gt-table"><thead><tr><th>class</th><th>placed/total</th><th>median position m</th>'
            f"<th>median depth m</th><th>median yaw °</th><th>median size m</th></tr></thead><tbody>{rows}</tbody></table>"
            f"<p class=sub>Matched by {how}; {summary.get('unmatched_placed', 0)} placed object(s) match no ground truth.</p>"
        )
    return "".join(out)


def _inputs_and_warnings(report: Mapping[str, Any]) -> str:
    warnings = report.get("warnings") or []
    items = "".join(f"<li>{escape(str(w))}</li>" for w in warnings) or "<li>none</li>"
    files = "".join(
        f"<tr><td>{escape(str(i.get('role', '')))}</td><td>{escape(str(i.get('name', '')))}</td><td><code>{escape(str(i.get('sha256', '')))}</code></td></tr>"
        for i in report.get("inputs", [])
    )
    params = escape(json.dumps(report.get("parameters", {}), indent=1, sort_keys=True))
    return (
        f'<h2 id="warnings">Build warnings</h2><ul class="warn">{items}</ul>'
        f'<h2 id="inputs">Inputs</h2><table><thead><tr><th>role</th><th>file</th><th>SHA-256</th></tr></thead><tbody>{files}</tbody></table>'
        f"<details><summary>Parameters of the build</summary><pre>{params}</pre></details>"
    )


def render_page(inputs: PageInputs) -> str:
    """The whole report page as HTML text.

    Args:
        inputs: what :func:`usdworld.report_html.collect.collect` gathered.
    """
    report = inputs.report
    title = f"usdworld report: {inputs.world_file.parent.name}"
    return (
        "<!DOCTYPE html>\n"
        f'<html lang="en"><head><meta charset="utf-8"><meta http-equiv="Content-Security-Policy" content="{CSP}">'
        f'<meta name="viewport" content="width=device-width, initial-scale=1"><title>{escape(title)}</title>'
        f"<style>{STYLE}</style></head><body>"
        f"<h1>{escape(title)}</h1>"
        f'<p class="sub">{escape(str(inputs.world_file))}: {len(report["objects"])} objects built from '
        f"{escape(str(report.get('source_image', '')))} by usdworld {escape(str(report.get('usdworld_version', '')))}.</p>"
        + _images(inputs)
        + _camera(report)
        + _objects(inputs)
        + _plots(report)
        + _evaluation(inputs)
        + _inputs_and_warnings(report)
        + f"<script>{SCRIPT}</script></body></html>\n"
    )


__all__ = ["COLUMNS", "CSP", "class_colours", "object_warnings", "render_page"]
