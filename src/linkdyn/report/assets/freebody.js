/* linkdyn report: the free-body view of one moving body at the frame shown. The body with
   every force on it at its point of application (report/data.py from design.free_body), the
   force polygon (the forces head to tail from the origin; the closing side, their sum, is
   m a_G by Newton's law) and a table of each force's components. LD.freebody(D) returns
   {draw(k)}; report.js calls it at every frame while the section is on the screen. A spatial
   page (geom.dim 3) has three components to each point and force: the drawing and the polygon
   are seen as the 3-D view's camera sees them (window.__linkdynCamera, view3d.js: screen right
   r and up u; a vector v drawn as (v . r, v . u)), the table has Fz. */
LD.freebody = function (D) {
  "use strict";
  var S = D.series, G = D.geom, N = D.t.length, DIM = G.dim === 3 ? 3 : 2, AX = "xyz".slice(0, DIM);
  var el = LD.el, h = LD.h, fin = LD.fin, fmt = LD.fmt;
  var sel = document.getElementById("fbody"), fbd = document.getElementById("fbd"),
      poly = document.getElementById("fbpoly"), table = document.getElementById("fbtable");
  var W = 320, H = 320;
  [fbd, poly].forEach(function (s) { s.setAttribute("viewBox", "0 0 " + W + " " + H); });
  var COLOR = {joint: LD.FORCE.joint, load: LD.FORCE.load, driver: LD.FORCE.driver,
               friction: LD.FORCE.friction, weight: LD.FORCE.weight, sum: "#111"};
  // an arrowhead per colour in each drawing
  [fbd, poly].forEach(function (s, n) {
    var defs = el("defs", {}, s);
    Object.keys(COLOR).forEach(function (c) {
      var mk = el("marker", {id: "fbh-" + n + "-" + c, viewBox: "0 0 10 10", refX: 9, refY: 5, markerWidth: 7,
                             markerHeight: 7, orient: "auto-start-reverse"}, defs);
      el("path", {d: "M0,0 L10,5 L0,10 z", fill: COLOR[c]}, mk);
    });
  });
  G.freebody.forEach(function (b, n) {
    var o = document.createElement("option"); o.value = String(n); o.textContent = b.body; sel.appendChild(o);
  });
  var place = LD.placer(W, H), shape = {};
  G.bodies.forEach(function (b) { shape[b.name] = b; });

  // a point at frame k (DIM components, m, global): a named point, or the mass centre (G) of
  // the body shown
  function P(b, id, k) {
    var p = id === "G" ? b.com : G.points[id];
    if (!p) return AX.split("").map(function () { return NaN; });
    return AX.split("").map(function (c) { return p.static ? p[c] : p[c][k]; });
  }
  // a force at frame k (DIM components, N, global): its sign times its series, or its
  // constant value
  function F(f, k) {
    if (f.value) return f.value;
    return AX.split("").map(function (c) { return f.sign * S[f[c]][k]; });
  }
  function norm(v) { var s = 0; v.forEach(function (x) { s += x * x; }); return Math.sqrt(s); }
  function finv(v) { return v.every(fin); }
  // a vector as drawn: itself in the plane; in space, on the 3-D view camera's screen axes
  var cam = null;
  function camera() {
    var c = window.__linkdynCamera || {az: 0, el: 0}, ca = Math.cos(c.az), sa = Math.sin(c.az),
        ce = Math.cos(c.el), se = Math.sin(c.el);
    cam = {az: c.az, el: c.el, r: [-sa, ca, 0], u: [-se * ca, -se * sa, ce]};
    poly.setAttribute("data-camera", JSON.stringify({r: cam.r, u: cam.u}));
  }
  function flat(v) {
    if (DIM === 2) return v;
    return [v[0] * cam.r[0] + v[1] * cam.r[1] + v[2] * cam.r[2], v[0] * cam.u[0] + v[1] * cam.u[1] + v[2] * cam.u[2]];
  }
  // each body's drawing scales, fixed over the run: the body's points within 0.3 of the
  // view about their centroid, its largest force 0.17 of it; the polygon's longest chain
  // (sum of |F|) within 0.45 of its view about the origin
  function scales(b) {
    if (b.sc) return b.sc;
    var ids = shape[b.body].points.concat(b.forces.map(function (f) { return f.at; })), R = 0, Fm = 0, Lm = 0;
    for (var k = 0; k < N; k++) {
      // (lengths in space bound their drawing from any side: the scales stay when it turns)
      var pts = ids.map(function (id) { return P(b, id, k); }).filter(finv);
      if (!pts.length) continue;
      var c = pts[0].map(function () { return 0; });
      pts.forEach(function (p) { p.forEach(function (x, n) { c[n] += x / pts.length; }); });
      pts.forEach(function (p) { R = Math.max(R, norm(p.map(function (x, n) { return x - c[n]; }))); });
      var L = 0;
      b.forces.forEach(function (f) { var m = norm(F(f, k)); if (fin(m)) { Fm = Math.max(Fm, m); L += m; } });
      Lm = Math.max(Lm, L);
    }
    b.sc = {len: R > 0 ? 0.3 * W / R : 1, force: Fm > 0 ? 0.17 * W / Fm : 0, poly: Lm > 0 ? 0.45 * W / Lm : 0};
    return b.sc;
  }
  function arrow(parent, x0, y0, x1, y1, kind, n, attrs) {
    var a = el("line", {x1: x0.toFixed(2), y1: y0.toFixed(2), x2: x1.toFixed(2), y2: y1.toFixed(2), stroke: COLOR[kind],
                        "stroke-width": kind === "sum" ? 2.6 : 2.2, "marker-end": "url(#fbh-" + n + "-" + kind + ")"}, parent);
    for (var k in attrs) a.setAttribute(k, attrs[k]);
    return a;
  }
  function clear(s) { Array.prototype.slice.call(s.childNodes).forEach(function (c) { if (c.tagName !== "defs") c.remove(); }); }

  // view units per screen pixel of the drawing (labels 11 px on the screen), measured once
  // and again after a resize (a measure between drawing steps would force a layout each frame)
  var ts0 = null;
  function textScale() {
    if (ts0 === null) { var w = fbd.getBoundingClientRect().width; ts0 = w > 0 ? Math.max(1, W / w) : 1; }
    return ts0;
  }
  window.addEventListener("resize", function () { ts0 = null; });
  // the table's rows, made once for the body shown: the forces, then their sum
  var rowsOf = null, rowsBody = null;
  function rows(b) {
    if (rowsBody === b) return rowsOf;
    table.innerHTML = "";
    var head = h("tr", "", h("thead", "", table));
    ["", "force on " + b.body, "at"].concat(AX.split("").map(function (c) { return "F" + c + " (N)"; }), ["|F| (N)"])
      .forEach(function (t) { h("th", "", head, t); });
    var body = h("tbody", "", table);
    function row(label, at, color, cls) {
      var tr = h("tr", cls || "", body);
      var sw = h("i", "", h("td", "", tr)); sw.style.background = color;
      h("td", "", tr, label); h("td", "", tr, at);
      tr.setAttribute("data-label", label);
      return {tr: tr, c: AX.split("").map(function () { return h("td", "num", tr); }), f: h("td", "num", tr)};
    }
    rowsOf = b.forces.map(function (f) { return row(f.label, f.at === "G" ? "mass centre" : f.at, COLOR[f.kind]); });
    rowsOf.push(row("sum = m a_G", "", COLOR.sum, "fbtotal"));
    rowsBody = b;
    return rowsOf;
  }
  // a row's numbers: 4 significant digits shown, every digit in data-fx, data-fy (data-fz)
  function fill(r, v) {
    AX.split("").forEach(function (c, n) { r.c[n].textContent = fmt(v[n], 4); r.tr.setAttribute("data-f" + c, v[n]); });
    r.f.textContent = fmt(norm(v), 4);
  }

  function draw(k) {
    var b = G.freebody[parseInt(sel.value, 10) || 0], sc = scales(b), sb = shape[b.body];
    textScale(); if (DIM === 3) camera();
    clear(fbd); clear(poly);
    var vals = b.forces.map(function (f) { return F(f, k); }), seen = vals.map(flat);
    // the body about its centroid at this frame (as the camera sees it, in space)
    var pts = sb.points.map(function (id) { return flat(P(b, id, k)); }), ok = pts.every(finv);
    var cx = 0, cy = 0;
    pts.forEach(function (p) { cx += p[0] / pts.length; cy += p[1] / pts.length; });
    function X(x) { return W / 2 + (x - cx) * sc.len; }
    function Y(y) { return H / 2 - (y - cy) * sc.len; }
    if (ok) {
      var xy = sb.outline.map(function (id) { var p = flat(P(b, id, k)); return [X(p[0]), Y(p[1])]; });
      var out = xy.map(function (p) { return p[0].toFixed(1) + "," + p[1].toFixed(1); });
      el(sb.shape === "polygon" ? "polygon" : "polyline", {points: out.join(" "), fill: sb.shape === "polygon" ? b.color : "none",
         "fill-opacity": 0.25, stroke: b.color, "stroke-width": sb.shape === "polygon" ? 3 : 8, "stroke-linecap": "round",
         "stroke-linejoin": "round", opacity: 0.8}, fbd);
      // every force at its point, at one scale (N per view unit); the labels by the arrows'
      // tips, clear of each other (LD.placer, at the edge with a leader when crowded)
      var items = [], ts = textScale();
      b.forces.forEach(function (f, n) {
        var p = flat(P(b, f.at, k)), v = seen[n];
        if (!finv(p) || !finv(v) || Math.hypot(v[0], v[1]) * sc.force < 1) return;
        var x = X(p[0]), y = Y(p[1]), tx = x + v[0] * sc.force, ty = y - v[1] * sc.force;
        arrow(fbd, x, y, tx, ty, f.kind, 0, {"data-label": f.label, "class": "fbforce"});
        var lab = el("text", {"font-size": 11, fill: COLOR[f.kind], "class": "fblabel"}, fbd);
        lab.textContent = f.label;
        var led = el("line", {stroke: COLOR[f.kind], "stroke-dasharray": "3 2"}, fbd);
        items.push({node: lab, x: tx, y: ty, fs: 11, r: 3, edge: true, leader: led});
      });
      // the labels keep clear of the drawn body too (its border or bar, half its stroke)
      place(items, [], ts, [{pts: xy, r: sb.shape === "polygon" ? 1.5 : 4, closed: sb.shape === "polygon"}]);
    } else el("text", {x: 10, y: 20, "font-size": 12, fill: "#555"}, fbd).textContent = "not assembled at this frame";
    // the force polygon: head to tail from the origin, the closing side from the origin to
    // the last head (the sum: m a_G)
    var ox = W / 2, oy = H / 2, px = 0, py = 0, bad = false, sum = AX.split("").map(function () { return 0; });
    poly.setAttribute("data-scale", sc.poly);
    el("circle", {cx: ox, cy: oy, r: 2.5, fill: "#111"}, poly);
    b.forces.forEach(function (f, n) {
      var v = seen[n];
      if (!finv(vals[n])) { bad = true; return; }
      vals[n].forEach(function (x, c) { sum[c] += x; });
      var x0 = ox + px * sc.poly, y0 = oy - py * sc.poly;
      px += v[0]; py += v[1];
      arrow(poly, x0, y0, ox + px * sc.poly, oy - py * sc.poly, f.kind, 1, {"data-label": f.label, "class": "fbside"});
    });
    if (bad) sum = sum.map(function () { return NaN; });   // a frame that is not solved: no sum
    else {
      var line = arrow(poly, ox, oy, ox + px * sc.poly, oy - py * sc.poly, "sum", 1, {"class": "fbsum", "stroke-dasharray": "5 3"});
      if (Math.hypot(px, py) * sc.poly < 1) line.removeAttribute("marker-end");
      el("text", {x: (ox + px * sc.poly / 2 + 4).toFixed(1), y: (oy - py * sc.poly / 2 - 4).toFixed(1), "font-size": 11.5,
                  "font-weight": "bold", fill: "#111"}, poly).textContent = "m a_G";
    }
    // the table: each force and the sum, N
    var rs = rows(b);
    vals.forEach(function (v, n) { fill(rs[n], v); });
    fill(rs[rs.length - 1], sum);
  }
  sel.addEventListener("change", function () { draw(window.__linkdynFrame || 0); });
  // in space, the drawing follows the 3-D view's camera: drawn again once a turn or zoom ends
  if (DIM === 3) {
    var redraw = function () { var c = window.__linkdynCamera; if (c && cam && (c.az !== cam.az || c.el !== cam.el)) draw(window.__linkdynFrame || 0); };
    ["pointerup", "click", "keyup"].forEach(function (e) { document.addEventListener(e, redraw); });
  }
  return {draw: draw};
};
