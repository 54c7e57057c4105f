"""The page's inline CSS and JavaScript (no network, no CDN: everything ships inside ``index.html``)."""

CSS = r"""
:root { --fg:#1d1f23; --muted:#5b6270; --line:#d9dde3; --bg:#fbfbfc; --card:#ffffff; --accent:#0072B2;
        --bad:#b3261e; --badbg:#fde7e6; --good:#1e6b3a; --goodbg:#e3f3e8; }
* { box-sizing: border-box; }
body { margin:0; font:14px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif;
       color:var(--fg); background:var(--bg); }
header.top { background:#20242c; color:#f2f3f5; padding:18px 28px 14px; }
header.top h1 { margin:0 0 4px; font-size:22px; font-weight:600; }
header.top .sub { color:#b8bec9; font-size:13px; }
nav.toc { padding:8px 28px; background:#2b303a; position:sticky; top:0; z-index:10; font-size:13px;
          display:flex; flex-wrap:wrap; row-gap:2px; }
nav.toc a { color:#d7e6ff; margin-right:16px; text-decoration:none; white-space:nowrap; }
nav.toc a:hover { text-decoration:underline; }
main { max-width:1560px; margin:0 auto; padding:8px 28px 40px; }
section.card { background:var(--card); border:1px solid var(--line); border-radius:8px; padding:14px 20px 18px;
               margin:18px 0; }
h2 { font-size:19px; margin:4px 0 10px; }
h3 { font-size:15px; margin:18px 0 8px; color:#2c3440; }
p.note, .note { color:var(--muted); font-size:12.5px; }
table.data { border-collapse:collapse; font-size:12.5px; font-variant-numeric:tabular-nums; width:100%; }
table.data th, table.data td { border-bottom:1px solid var(--line); padding:4px 8px; text-align:right;
                               white-space:nowrap; }
table.data th { white-space:normal; vertical-align:bottom; }
table.data th { background:#f1f3f6; font-weight:600; cursor:help; }
table.data td:first-child, table.data th:first-child { text-align:left; }
table.data tr:nth-child(even) td { background:#fafbfc; }
table.data tr.mitsuba td { background:#f4f4f4; font-weight:500; }
td.biased { color:var(--bad); background:var(--badbg) !important; font-weight:600; }
td.unbiased { color:var(--good); background:var(--goodbg) !important; }
td.nocost { color:var(--muted); font-style:italic; }
.tablewrap { overflow-x:auto; }
table.facts { border-collapse:collapse; font-size:13px; }
table.facts th { text-align:left; color:var(--muted); font-weight:500; padding:2px 18px 2px 0; vertical-align:top; }
table.facts td { padding:2px 0; }
.plots { display:grid; grid-template-columns:repeat(auto-fit, minmax(min(520px, 100%), 1fr)); gap:12px 18px; }
figure { margin:0; }
figure.plot img { width:100%; height:auto; border:1px solid var(--line); border-radius:4px; background:white; }
figcaption { font-size:12px; color:var(--muted); margin-top:2px; }
.swatch { display:inline-block; width:10px; height:10px; border-radius:2px; margin-right:4px; vertical-align:-1px; }
.cmp-row { margin:10px 0 18px; }
.cmp-row h4 { margin:6px 0; font-size:13.5px; }
.cmp-grid { display:grid; gap:8px; align-items:start; }
.cmp-scroll { overflow-x:auto; }
.cell { min-width:0; }
.cell .lbl { font-size:12.5px; font-weight:600; margin-bottom:2px; overflow:hidden; text-overflow:ellipsis;
             white-space:nowrap; }
.shotwrap { position:relative; line-height:0; outline:none; }
.shotwrap:focus-visible { outline:2px solid var(--accent); outline-offset:1px; }
img.shot, img.err { width:100%; height:auto; image-rendering:pixelated; border-radius:2px; background:#000; }
img.shot { cursor:pointer; }
.shotwrap .badge { display:none; position:absolute; left:4px; top:4px; background:rgba(0,0,0,.72); color:#fff;
                   font:600 11px/1 system-ui, sans-serif; padding:3px 5px; border-radius:3px; }
.shotwrap.flipped .badge { display:block; }
.shotwrap.flipped img.shot { outline:2px solid #ffd54a; }
.cropbox { position:absolute; border:1.5px solid #ffd54a; box-shadow:0 0 0 1px rgba(0,0,0,.55);
           pointer-events:none; display:none; }
.cmp-row.zooming .cropbox { display:block; }
.cell.sub { display:grid; grid-template-columns:1fr 1fr; gap:4px; margin-top:4px; }
.cell.sub.three { grid-template-columns:1fr 1fr 1fr; }
.cell .cap, .cell.cap { font-size:11px; color:var(--muted); line-height:1.3; margin:2px 0 4px; font-variant-numeric:tabular-nums; }
canvas.zoom { width:100%; height:auto; image-rendering:pixelated; background:#111; border-radius:2px; }
.empty { display:flex; align-items:center; justify-content:center; aspect-ratio:1/1; background:#eceef1;
         color:var(--muted); font-size:12px; border-radius:2px; line-height:1.2; }
.cbar img { max-width:620px; width:100%; }
.help { font-size:12.5px; background:#f3f6fb; border:1px solid #dfe7f3; border-radius:6px; padding:6px 10px; }
kbd { font:11px ui-monospace, monospace; border:1px solid #c9ced6; border-bottom-width:2px; border-radius:3px;
      padding:0 4px; background:#fff; }
dl.formulas dt { font-weight:600; margin-top:6px; }
dl.formulas dd { margin:0 0 0 18px; color:#333a45; }
ul.problems li { color:var(--bad); }
.big { font-size:15px; }
table.headline td { white-space:nowrap; padding:3px 7px; }
table.headline td:nth-child(2), table.headline td:nth-child(3) { white-space:normal; max-width:12em; }
table.headline td:nth-child(2) { min-width:11.5em; }
table.headline td:nth-child(3) { min-width:7.5em; }
table.headline th { padding:3px 7px; }
table.headline th .sub { font-weight:400; color:var(--muted); font-size:11px; }
.seedgrid { display:grid; grid-template-columns:repeat(auto-fill, minmax(min(180px, 100%), 1fr)); gap:10px;
            margin-bottom:8px; max-width:1300px; }
.seedgrid img { width:100%; height:auto; border-radius:2px; background:#000; display:block; }
.seedgrid figcaption { font-size:12px; }
table.direct-grid td, table.direct-grid th { padding:4px 6px; vertical-align:top; font-size:12px; }
table.direct-grid img { width:min(150px, 11vw); height:auto; image-rendering:pixelated; background:#000;
                        display:block; border-radius:2px; }
details.scene-details > summary { cursor:pointer; list-style:revert; }
details.scene-details > summary h2 { display:inline; margin-right:12px; }
.cmp-grid img.shot, .cmp-grid canvas.zoom { min-width:0; }
.shotwrap img.shot { border:1px solid #555; }
footer { color:var(--muted); font-size:12px; text-align:center; padding:10px; overflow-wrap:anywhere; }
table.facts td { overflow-wrap:anywhere; }
@media (max-width: 700px) {
  header.top { padding:12px 12px 10px; }
  nav.toc { padding:6px 12px; }
  main { padding:4px 8px 24px; }
  section.card { padding:10px 10px 12px; }
  .cell .cap, .cell.cap { font-size:10px; }
}
"""

JS = r"""
(function () {
  "use strict";
  var zoom = 4;            // crop = 1/zoom of the image side
  var hovered = null;      // .shotwrap under the pointer
  function wraps(root) { return Array.prototype.slice.call((root || document).querySelectorAll(".shotwrap")); }
  function setFlip(w, on) {
    var img = w.querySelector("img.shot");
    var ref = document.getElementById(w.getAttribute("data-ref"));
    if (!img || !ref || w.classList.contains("is-ref")) return;
    if (!img.getAttribute("data-own")) img.setAttribute("data-own", img.src);
    img.src = on ? ref.src : img.getAttribute("data-own");
    w.classList.toggle("flipped", on);
  }
  function toggle(w) { setFlip(w, !w.classList.contains("flipped")); }
  function rowDraw(row) {
    var u = parseFloat(row.getAttribute("data-u") || "0.5"), v = parseFloat(row.getAttribute("data-v") || "0.5");
    wraps(row).forEach(function (w) {
      var img = w.querySelector("img.shot"), c = document.getElementById(w.getAttribute("data-zoom"));
      if (!img || !c || !img.naturalWidth) return;
      var W = img.naturalWidth, H = img.naturalHeight;
      var cw = Math.max(1, Math.round(W / zoom)), ch = Math.max(1, Math.round(H / zoom));
      var x = Math.min(Math.max(0, Math.round(u * W - cw / 2)), W - cw);
      var y = Math.min(Math.max(0, Math.round(v * H - ch / 2)), H - ch);
      var ctx = c.getContext("2d");
      ctx.imageSmoothingEnabled = false;
      ctx.clearRect(0, 0, c.width, c.height);
      ctx.drawImage(img, x, y, cw, ch, 0, 0, c.width, c.height);
      var box = w.querySelector(".cropbox");
      if (box) {
        box.style.left = (100 * x / W) + "%"; box.style.top = (100 * y / H) + "%";
        box.style.width = (100 * cw / W) + "%"; box.style.height = (100 * ch / H) + "%";
      }
    });
    var z = row.querySelector(".zoomlevel");
    if (z) z.textContent = "\u00d7" + zoom;
  }
  function allRows() { return Array.prototype.slice.call(document.querySelectorAll(".cmp-row")); }
  function init() {
    allRows().forEach(function (row) {
      row.querySelectorAll("canvas.zoom").forEach(function (c) {
        var a = parseFloat(c.getAttribute("data-aspect") || "1");
        c.width = 240; c.height = Math.max(1, Math.round(240 * a));
      });
      wraps(row).forEach(function (w) {
        var img = w.querySelector("img.shot");
        w.addEventListener("click", function () { toggle(w); });
        w.addEventListener("mouseenter", function () { hovered = w; row.classList.add("zooming"); });
        w.addEventListener("mouseleave", function () { if (hovered === w) hovered = null; });
        w.addEventListener("focus", function () { hovered = w; });
        w.addEventListener("mousemove", function (e) {
          var r = img.getBoundingClientRect();
          row.setAttribute("data-u", String((e.clientX - r.left) / r.width));
          row.setAttribute("data-v", String((e.clientY - r.top) / r.height));
          rowDraw(row);
        });
        img.addEventListener("load", function () { rowDraw(row); });
      });
      rowDraw(row);
    });
    document.addEventListener("keydown", function (e) {
      if (e.ctrlKey || e.metaKey || e.altKey) return;
      var k = e.key;
      if ((k === "r" || k === " " || k === "Enter") && hovered) { toggle(hovered); e.preventDefault(); }
      else if (k === "R" && hovered) {
        var row = hovered.closest(".cmp-row"), ws = wraps(row);
        var on = !ws.some(function (w) { return w.classList.contains("flipped"); });
        ws.forEach(function (w) { setFlip(w, on); });
      }
      else if (k === "Escape") { wraps().forEach(function (w) { setFlip(w, false); }); }
      else if (k === "+" || k === "=") { zoom = Math.min(32, zoom * 2); allRows().forEach(rowDraw); }
      else if (k === "-" || k === "_") { zoom = Math.max(1, zoom / 2); allRows().forEach(rowDraw); }
    });
  }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", init); else init();
  window.addEventListener("load", function () { allRows().forEach(rowDraw); });
})();
"""
