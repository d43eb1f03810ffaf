/* linkdyn report: animation + plots synchronised on one time cursor. Inlined into report.html;
   reads the JSON in #linkdyn-data; no network, no library. */
(function () {
  "use strict";
  var D = JSON.parse(document.getElementById("linkdyn-data").textContent);
  var S = D.series, G = D.geom, T = D.t, N = T.length;
  var anim = document.getElementById("anim");
  var NS = anim.namespaceURI;
  var frame = 0, playing = false, simT = T[0], last = null, speed = 1;
  var xmode = D.xaxes[0];
  var plots = [];
  window.__linkdynFrame = 0;
  window.__linkdynPlayed = 0;

  // ------------------------------------------------------------------ helpers (assets/common.js)
  var el = LD.el, h = LD.h, fin = LD.fin, fmt = LD.fmt, nearest = LD.nearest, niceStep = LD.niceStep,
      tickText = LD.tickText, range = LD.range;
  // a series' values with the decimals its peak needs for 4 significant digits, so numbers
  // near a zero crossing keep the same format
  var SCALE = {};
  function fmtS(key, v) {
    if (!fin(v)) return "–";
    if (!(key in SCALE)) {
      var m = 0, a = S[key];
      for (var i = 0; i < a.length; i++) if (fin(a[i]) && Math.abs(a[i]) > m) m = Math.abs(a[i]);
      SCALE[key] = m;
    }
    var sc0 = SCALE[key];
    if (!(sc0 > 0)) return fmt(v);
    if (sc0 >= 1e6 || sc0 < 1e-3) return v.toExponential(3);
    var s = v.toFixed(Math.max(0, 3 - Math.floor(Math.log10(sc0))));
    return /^-0\.?0*$/.test(s) ? s.slice(1) : s;
  }
  function lowerBound(arr, x) {  // last index with arr[i] <= x (arr increasing)
    var lo = 0, hi = arr.length - 1;
    if (x <= arr[0]) return 0;
    if (x >= arr[hi]) return hi;
    while (hi - lo > 1) { var mid = (lo + hi) >> 1; if (arr[mid] <= x) lo = mid; else hi = mid; }
    return (x - arr[lo] <= arr[hi] - x) ? lo : hi;
  }

  // ------------------------------------------------------------------ animation
  // pixel units of about the displayed size, whatever the mechanism's aspect ratio
  var B = G.bounds, sc = Math.min(640 / (B[2] - B[0]), 520 / (B[3] - B[1]));
  var VW = (B[2] - B[0]) * sc, VH = (B[3] - B[1]) * sc;
  anim.setAttribute("viewBox", "0 0 " + VW + " " + VH.toFixed(1));
  function X(x) { return (x - B[0]) * sc; }
  function Y(y) { return (B[3] - y) * sc; }
  function P(id, k) {
    var p = G.points[id];
    if (p.static) return [p.x, p.y];
    return [p.x[k], p.y[k]];
  }
  var defs = el("defs", {}, anim);
  var pat = el("pattern", {id: "hatch", width: 6, height: 6, patternUnits: "userSpaceOnUse",
                           patternTransform: "rotate(45)"}, defs);
  el("line", {x1: 0, y1: 0, x2: 0, y2: 6, stroke: "#666", "stroke-width": 1.6}, pat);
  var mk = el("marker", {id: "arrowhead", viewBox: "0 0 10 10", refX: 9, refY: 5, markerWidth: 7,
                         markerHeight: 7, orient: "auto-start-reverse"}, defs);
  el("path", {d: "M0,0 L10,5 L0,10 z", fill: "#c62828"}, mk);
  [["arrow-load", "#1565c0"], ["arrow-shake", "#6a1b9a"], ["arrow-drv", "#2e7d32"]].forEach(function (m) {
    var k = el("marker", {id: m[0], viewBox: "0 0 10 10", refX: 9, refY: 5, markerWidth: 7,
                          markerHeight: 7, orient: "auto-start-reverse"}, defs);
    el("path", {d: "M0,0 L10,5 L0,10 z", fill: m[1]}, k);
  });

  var gGround = el("g", {}, anim), gTraces = el("g", {}, anim), gBodies = el("g", {}, anim),
      gSliders = el("g", {}, anim), gForces = el("g", {}, anim), gJoints = el("g", {}, anim),
      gLabels = el("g", {"class": "labels"}, anim), gFLabels = el("g", {"class": "labels flabels"}, anim);
  gForces.style.display = gFLabels.style.display = "none";
  var showForces = false, showLabels = true;

  // scale bar: a round length about a fifth of the view
  (function () {
    var span = (B[2] - B[0]) / 5, mag = Math.pow(10, Math.floor(Math.log10(span)));
    var L = [1, 2, 5, 10].map(function (f) { return f * mag; }).filter(function (v) { return v <= span; }).pop() || mag;
    var x0 = 14, y0 = VH - 12, w = L * sc;
    el("line", {x1: x0, y1: y0, x2: x0 + w, y2: y0, stroke: "#444", "stroke-width": 2}, gGround);
    el("line", {x1: x0, y1: y0 - 4, x2: x0, y2: y0 + 4, stroke: "#444", "stroke-width": 2}, gGround);
    el("line", {x1: x0 + w, y1: y0 - 4, x2: x0 + w, y2: y0 + 4, stroke: "#444", "stroke-width": 2}, gGround);
    var txt = L >= 1 ? fmt(L, 3) + " m" : fmt(L * 1000, 3) + " mm";
    el("text", {x: x0 + w + 6, y: y0 + 4, "font-size": 12, fill: "#444", "class": "legtext"}, gGround).textContent = txt;
  })();

  // ground link: a dashed line through the ground pivots
  if (G.ground.length > 1) {
    var gp = G.ground.map(function (id) { var p = P(id, 0); return X(p[0]).toFixed(1) + "," + Y(p[1]).toFixed(1); });
    el(G.ground.length > 2 ? "polygon" : "polyline", {points: gp.join(" "), fill: "none", stroke: "#9aa3ab",
                    "stroke-width": 2, "stroke-dasharray": "6 5"}, gGround);
  }
  // pivots on the ground: a hatched triangle; fixed slider guides: a hatched bar
  G.joints.forEach(function (j) {
    if (!j.ground) return;
    if (j.kind === "revolute") {
      var gid = j.first === "ground" ? j.a : j.b, p = P(gid, 0), x = X(p[0]), y = Y(p[1]);
      el("path", {d: "M" + x + "," + y + " l-11,18 h22 z", fill: "#e9ecef", stroke: "#555",
                  "stroke-width": 1.5}, gGround);
      el("rect", {x: x - 16, y: y + 18, width: 32, height: 7, fill: "url(#hatch)"}, gGround);
      el("line", {x1: x - 16, y1: y + 18, x2: x + 16, y2: y + 18, stroke: "#555", "stroke-width": 1.5}, gGround);
    } else if (j.guide) {
      var g = j.guide, x0 = X(g[0]), y0 = Y(g[1]), x1 = X(g[2]), y1 = Y(g[3]);
      var len = Math.hypot(x1 - x0, y1 - y0), ang = Math.atan2(y1 - y0, x1 - x0) * 180 / Math.PI;
      var grp = el("g", {transform: "translate(" + x0 + "," + y0 + ") rotate(" + ang + ")"}, gGround);
      el("rect", {x: 0, y: 10, width: len, height: 7, fill: "url(#hatch)"}, grp);
      el("line", {x1: 0, y1: 10, x2: len, y2: 10, stroke: "#555", "stroke-width": 1.5}, grp);
      el("line", {x1: 0, y1: 0, x2: len, y2: 0, stroke: "#9aa3ab", "stroke-width": 1,
                  "stroke-dasharray": "4 4"}, grp);
    }
  });

  // traced points: the whole path, faint, and a dot at the current position
  var traces = G.traces.map(function (id) {
    var body = G.bodies.filter(function (b) { return b.points.indexOf(id) >= 0; })[0];
    var color = body ? body.color : "#555", p = G.points[id], d = "", pen = false;
    for (var k = 0; k < N; k++) {
      if (fin(p.x[k]) && fin(p.y[k])) { d += (pen ? "L" : "M") + X(p.x[k]).toFixed(1) + "," + Y(p.y[k]).toFixed(1); pen = true; }
      else pen = false;
    }
    el("path", {d: d, fill: "none", stroke: color, "stroke-width": 1.6, opacity: 0.45}, gTraces);
    var dot = el("circle", {r: 4, fill: color, stroke: "#fff", "stroke-width": 1.2}, gTraces);
    var lab = el("text", {"font-size": 12, fill: "#222", "font-weight": "bold"}, gLabels);
    lab.textContent = id.split(".")[1];
    return {id: id, dot: dot, lab: lab};
  });

  // bodies
  var bodies = G.bodies.map(function (b) {
    var node;
    if (b.shape === "polygon")
      node = el("polygon", {fill: b.color, "fill-opacity": 0.35, stroke: b.color, "stroke-width": 4,
                            "stroke-linejoin": "round"}, gBodies);
    else if (b.shape === "dot")
      node = el("circle", {r: 6, fill: b.color}, gBodies);
    else
      node = el("line", {stroke: b.color, "stroke-width": 9, "stroke-linecap": "round", opacity: 0.9}, gBodies);
    var lab = el("text", {"font-size": 12, fill: b.color, "text-anchor": "middle", "font-style": "italic"}, gLabels);
    lab.textContent = b.name;
    return {b: b, node: node, lab: lab};
  });

  // sliders (prismatic joints): a block along the axis at the second body's point; slots: the
  // first body's slot, an outline along the axis around the pin
  var sliders = G.joints.filter(function (j) { return j.kind === "prismatic" || j.kind === "slot"; }).map(function (j) {
    var slot = j.kind === "slot";
    var body = G.bodies.filter(function (b) { return b.name === (slot ? j.first : j.second); })[0];
    var color = body ? body.color : "#888", g = el("g", {}, gSliders);
    el("rect", slot ? {x: -26, y: -7, width: 52, height: 14, rx: 7, fill: "none", stroke: color,
                       "stroke-width": 3}
                    : {x: -18, y: -9, width: 36, height: 18, rx: 2, fill: color,
                       "fill-opacity": 0.85, stroke: "#333", "stroke-width": 1.5}, g);
    return {j: j, g: g};
  });

  // joints
  var joints = G.joints.map(function (j) {
    var c = j.kind === "revolute" ? el("circle", {r: 5.5, fill: "#fff", stroke: "#222", "stroke-width": 2}, gJoints)
                                  : el("circle", {r: 3, fill: "#222"}, gJoints);
    var lab = el("text", {"font-size": 11.5, fill: "#222"}, gLabels);
    lab.textContent = j.name;
    var arrow = el("line", {stroke: "#c62828", "stroke-width": 2.2, "marker-end": "url(#arrowhead)",
                            "class": "farrow", "data-joint": j.name}, gForces);
    var flab = el("text", {"font-size": 11, fill: "#c62828"}, gFLabels);
    return {j: j, c: c, lab: lab, arrow: arrow, flab: flab};
  });
  var ring = el("circle", {r: 11, fill: "none", stroke: "#c62828", "stroke-width": 2.5}, gJoints);

  // instant centres of velocity (toggle, off by default): a small crossed ring per moving body
  // in its colour, labelled I_body; none while the body translates or when out of view
  var gIC = el("g", {"class": "ics"}, anim), gICLabels = el("g", {"class": "labels iclabels"}, anim);
  gIC.style.display = gICLabels.style.display = "none";
  var showICs = false;
  var ics = (G.ics || []).map(function (c) {
    var g = el("g", {"class": "icmark", "data-body": c.body}, gIC);
    el("circle", {r: 5, fill: "#fff", stroke: c.color, "stroke-width": 2}, g);
    el("path", {d: "M-7,0H7M0,-7V7", stroke: c.color, "stroke-width": 1.5}, g);
    var lab = el("text", {"font-size": 11, fill: c.color, "font-weight": "bold", "class": "iclabel"}, gICLabels);
    lab.textContent = "I " + c.body;
    return {c: c, g: g, lab: lab};
  });

  // forces: one scale (viewBox units per N) for every arrow, shown by a legend bar of a round
  // force; the largest force drawn is about a fifth of the view
  function seriesMax(key) {
    var a = S[key], m = 0;
    if (!a) return 0;
    for (var i = 0; i < a.length; i++) if (fin(a[i]) && Math.abs(a[i]) > m) m = Math.abs(a[i]);
    return m;
  }
  function hyp(kx, ky) {
    var m = 0;
    for (var i = 0; i < N; i++) { var v = Math.hypot(S[kx][i], S[ky][i]); if (fin(v) && v > m) m = v; }
    return m;
  }
  var fall = G.fmax || 0;
  (G.loads || []).forEach(function (l) { if (l.kind === "force") fall = Math.max(fall, hyp(l.x, l.y)); });
  if (G.shaking) fall = Math.max(fall, hyp(G.shaking.fx, G.shaking.fy));
  D.drivers.forEach(function (d) { if (d.unit === "N") fall = Math.max(fall, seriesMax(d.key)); });
  // the scale's force: the 95th percentile over the frames of the largest force drawn in each
  // (not the run's peak), so that a brief peak (the start of a run-up, a dead point) does not
  // shrink every other frame's arrows to nothing; an arrow of a peak frame may leave the view
  var frameMax = [];
  for (var i = 0; i < N; i++) frameMax.push(0);
  function biggest(kx, ky) {
    if (!S[kx] || (ky && !S[ky])) return;
    for (var i = 0; i < N; i++) {
      var v = ky ? Math.hypot(S[kx][i], S[ky][i]) : Math.abs(S[kx][i]);
      if (fin(v) && v > frameMax[i]) frameMax[i] = v;
    }
  }
  G.joints.forEach(function (j) { biggest("Fx:" + j.name, "Fy:" + j.name); });
  (G.loads || []).forEach(function (l) { if (l.kind === "force") biggest(l.x, l.y); });
  if (G.shaking) biggest(G.shaking.fx, G.shaking.fy);
  D.drivers.forEach(function (d) { if (d.unit === "N") biggest(d.key); });
  var ranked = frameMax.filter(function (v) { return v > 0; }).sort(function (a, b) { return a - b; });
  if (ranked.length) fall = Math.min(fall, ranked[Math.floor(0.95 * (ranked.length - 1))]);
  var fscale = fall > 0 ? 0.2 * Math.min(VW, VH * 1.6) / fall : 0;
  var fleg = null;
  if (fscale > 0) {
    var mag = Math.pow(10, Math.floor(Math.log10(fall / 2.5)));
    var Fr = [1, 2, 5, 10].map(function (f) { return f * mag; }).filter(function (v) { return v <= fall / 2.5 * 1.0001; }).pop() || mag;
    var lx1 = VW - 14, lx0 = lx1 - Fr * fscale, ly = VH - 12;
    fleg = el("g", {id: "force-legend", "data-force": Fr, "data-length": (Fr * fscale).toFixed(4)}, gForces);
    el("line", {x1: lx0, y1: ly, x2: lx1, y2: ly, stroke: "#c62828", "stroke-width": 2.2, "marker-end": "url(#arrowhead)"}, fleg);
    el("text", {x: lx0 - 6, y: ly + 4, "text-anchor": "end", "font-size": 12, fill: "#c62828", "class": "legtext"}, fleg).textContent =
      "force scale: " + fmt(Fr, 3) + " N";
  }
  window.__linkdynForces = {scale: fscale};
  // external loads, the driver efforts and the shaking force on the frame
  var loadArrows = (G.loads || []).map(function (l) {
    var line = l.kind === "spring" || l.kind === "damper";
    // springs and dampers are part of the drawing (below the bodies' joints), their tension a label
    var a = l.kind === "force" ? el("line", {stroke: "#1565c0", "stroke-width": 2.2, "marker-end": "url(#arrow-load)", "class": "farrow"}, gForces)
          : line ? el("path", {fill: "none", stroke: "#455a64", "stroke-width": 1.6, "class": "f" + l.kind, "data-load": l.label}, gSliders)
          : el("path", {fill: "none", stroke: "#1565c0", "stroke-width": 2, "marker-end": "url(#arrow-load)", "class": "ftorque"}, gForces);
    var t = el("text", {"font-size": 11, fill: "#1565c0"}, gFLabels);
    return {l: l, a: a, t: t};
  });
  function zigzag(x0, y0, x1, y1, kind, lane) {  // a spring's zigzag or a damper's pot between two points
    var dx = x1 - x0, dy = y1 - y0, L = Math.hypot(dx, dy) || 1, ux = dx / L, uy = dy / L, nx = -uy, ny = ux;
    var w = 5, a = 0.2 * L, b = 0.8 * L, off = 14 * (lane || 0);   // side by side: 14 px a lane
    function at(s, o) { return (x0 + ux * s + nx * (o + off)).toFixed(1) + "," + (y0 + uy * s + ny * (o + off)).toFixed(1); }
    var from = "M" + x0.toFixed(1) + "," + y0.toFixed(1) + " L" + at(0.1 * L, 0), to = " L" + x1.toFixed(1) + "," + y1.toFixed(1);
    if (kind === "damper") {  // a rod with its plate inside a pot (the cylinder's three sides)
      var m = 0.5 * L;
      return from + " L" + at(m, 0) + " M" + at(m, -w * 0.8) + " L" + at(m, w * 0.8) +
             " M" + at(a + 0.1 * L, -w) + " L" + at(b, -w) + " L" + at(b, w) + " L" + at(a + 0.1 * L, w) +
             " M" + at(b, 0) + " L" + at(0.9 * L, 0) + to;
    }
    var d = from + " L" + at(a, 0), n = 8;
    for (var i = 1; i < n; i++) d += " L" + at(a + (b - a) * i / n, i % 2 ? w : -w);
    return d + " L" + at(b, 0) + " L" + at(0.9 * L, 0) + to;
  }
  var drvArrows = D.drivers.map(function (d) {
    var j = G.joints.filter(function (x) { return x.name === d.joint; })[0];
    var a = d.unit === "N m" ? el("path", {fill: "none", stroke: "#2e7d32", "stroke-width": 2.4, "marker-end": "url(#arrow-drv)"}, gForces)
                             : el("line", {stroke: "#2e7d32", "stroke-width": 2.4, "marker-end": "url(#arrow-drv)", "class": "farrow"}, gForces);
    var t = el("text", {"font-size": 11, fill: "#2e7d32"}, gFLabels);
    return {d: d, j: j, a: a, t: t};
  });
  var shake = G.shaking ? {a: el("line", {stroke: "#6a1b9a", "stroke-width": 2.4, "marker-end": "url(#arrow-shake)", "class": "farrow"}, gForces),
                           t: el("text", {"font-size": 11, fill: "#6a1b9a"}, gFLabels)} : null;
  function arc(x, y, r, m) {  // a 270-degree arc around (x, y), counter-clockwise for m > 0
    var a0 = Math.PI * 0.75, a1 = a0 + (m >= 0 ? 1 : -1) * Math.PI * 1.5;
    var p0 = [x + r * Math.cos(a0), y - r * Math.sin(a0)], p1 = [x + r * Math.cos(a1), y - r * Math.sin(a1)];
    return "M" + p0[0].toFixed(1) + "," + p0[1].toFixed(1) + " A" + r + "," + r + " 0 1 " + (m >= 0 ? 0 : 1) + " " + p1[0].toFixed(1) + "," + p1[1].toFixed(1);
  }
  function setLine(a, x, y, fx, fy) {
    var ok = fin(fx) && fin(fy) && fscale > 0 && Math.hypot(fx, fy) * fscale > 2;
    a.style.display = ok ? "" : "none";
    if (ok) {
      a.setAttribute("x1", x.toFixed(2)); a.setAttribute("y1", y.toFixed(2));
      a.setAttribute("x2", (x + fx * fscale).toFixed(2)); a.setAttribute("y2", (y - fy * fscale).toFixed(2));
    }
    return ok;
  }

  // ------------------------------------------------------------------ label placement
  // each label goes to the first of a ring of positions around its anchor whose box overlaps
  // no label placed before it and no pivot; sizes in screen pixels whatever the zoom
  var textScale = 1;
  function updateTextScale() {
    var w = anim.getBoundingClientRect().width;
    textScale = w > 0 ? Math.max(1, VW / w) : 1;
    // the scale bars' texts: 12 px on the screen whatever the zoom
    Array.prototype.forEach.call(anim.querySelectorAll(".legtext"), function (t) {
      t.setAttribute("font-size", (12 * textScale).toFixed(1));
    });
  }
  var widthCache = {};
  function textBox(node, fs) {
    // digits share one width: "J3 135.8 N" and "J3 121.4 N" are measured once
    var key = node.textContent.replace(/[0-9]/g, "0") + "|" + fs + "|" + (node.getAttribute("font-weight") || "") + (node.getAttribute("font-style") || "");
    if (!(key in widthCache)) {
      node.setAttribute("font-size", fs);
      var w = 0;
      try { w = node.getComputedTextLength(); } catch (err) { w = 0; }
      widthCache[key] = w > 0 ? w : 0.62 * fs * node.textContent.length;
    }
    return [widthCache[key], fs];
  }
  var DIRS = [[1, -1], [1, 1], [-1, -1], [-1, 1], [0, -1], [0, 1], [1, 0], [-1, 0]];
  function overlaps(b, boxes) {
    for (var i = 0; i < boxes.length; i++) {
      var o = boxes[i];
      if (b[0] < o[2] && o[0] < b[2] && b[1] < o[3] && o[1] < b[3]) return true;
    }
    return false;
  }
  function place(items, obstacles) {
    var placed = obstacles.slice();
    items.forEach(function (it) {
      if (it.node.style.display === "none" || !fin(it.x) || !fin(it.y)) return;
      var fs = it.fs * textScale, wh = textBox(it.node, fs), w = wh[0] + 2, hgt = fs * 1.05;
      var pad = 2 * textScale, best = null;
      var dirs = it.prefer ? [it.prefer].concat(DIRS) : DIRS;
      for (var ring = 0; ring < 4 && !best; ring++) {
        var r = (it.r || 6) * textScale + ring * 10 * textScale;
        for (var n = 0; n < dirs.length; n++) {
          var dx = dirs[n][0], dy = dirs[n][1];
          var x0 = it.x + dx * r - (dx < 0 ? w : dx === 0 ? w / 2 : 0);
          var y0 = it.y + dy * r - (dy < 0 ? hgt : dy === 0 ? hgt / 2 : 0);
          var b = [x0 - pad, y0 - pad, x0 + w + pad, y0 + hgt + pad];
          if (b[0] < 0 || b[2] > VW || b[1] < 0 || b[3] > VH) continue;
          if (!overlaps(b, placed)) { best = b; break; }
        }
      }
      if (!best) { it.node.style.display = "none"; return; }  // no room: left out this frame
      placed.push(best);
      it.node.setAttribute("font-size", fs.toFixed(2));
      it.node.setAttribute("text-anchor", "start");
      it.node.setAttribute("x", (best[0] + pad).toFixed(1));
      it.node.setAttribute("y", (best[1] + pad + 0.8 * hgt).toFixed(1));
    });
  }

  function drawAnim(k) {
    bodies.forEach(function (o) {
      var b = o.b, pts = b.outline.map(function (id) { return P(id, k); });
      var ok = pts.every(function (p) { return fin(p[0]) && fin(p[1]); });
      o.node.style.display = ok ? "" : "none";
      o.lab.style.display = ok ? "" : "none";
      if (!ok) return;
      if (b.shape === "polygon")
        o.node.setAttribute("points", pts.map(function (p) { return X(p[0]).toFixed(1) + "," + Y(p[1]).toFixed(1); }).join(" "));
      else if (b.shape === "dot") { o.node.setAttribute("cx", X(pts[0][0])); o.node.setAttribute("cy", Y(pts[0][1])); }
      else {
        var e = pts.length - 1;
        o.node.setAttribute("x1", X(pts[0][0])); o.node.setAttribute("y1", Y(pts[0][1]));
        o.node.setAttribute("x2", X(pts[e][0])); o.node.setAttribute("y2", Y(pts[e][1]));
      }
      // body label: at the centroid of a plate, mid-way along the longest span of a bar,
      // pushed off the body
      var cx = 0, cy = 0;
      if (b.shape === "polygon" || pts.length < 2) {
        pts.forEach(function (p) { cx += X(p[0]); cy += Y(p[1]); });
        cx /= pts.length; cy /= pts.length;
      } else {
        var gap = -1;
        for (var n = 0; n + 1 < pts.length; n++) {
          var gl = Math.hypot(pts[n + 1][0] - pts[n][0], pts[n + 1][1] - pts[n][1]);
          if (gl > gap * (1 + 1e-6)) { gap = gl; cx = (X(pts[n][0]) + X(pts[n + 1][0])) / 2; cy = (Y(pts[n][1]) + Y(pts[n + 1][1])) / 2; }
        }
      }
      var nx = 0, ny = -1;
      if (pts.length >= 2) {
        var dx = X(pts[pts.length - 1][0]) - X(pts[0][0]), dy = Y(pts[pts.length - 1][1]) - Y(pts[0][1]);
        var L = Math.hypot(dx, dy) || 1; nx = dy / L; ny = -dx / L;
        if (ny > 0) { nx = -nx; ny = -ny; }
      }
      o.ax = cx; o.ay = cy;
      o.pref = [Math.abs(nx) < 0.35 ? 0 : nx > 0 ? 1 : -1, Math.abs(ny) < 0.35 ? 0 : ny > 0 ? 1 : -1];
    });
    sliders.forEach(function (o) {
      var p = P(o.j.b, k), a = o.j.angle[k];
      var ok = fin(p[0]) && fin(p[1]) && fin(a);
      o.g.style.display = ok ? "" : "none";
      if (ok) o.g.setAttribute("transform", "translate(" + X(p[0]).toFixed(1) + "," + Y(p[1]).toFixed(1) + ") rotate(" + (-a * 180 / Math.PI).toFixed(2) + ")");
    });
    var best = -1, bestF = -1;
    joints.forEach(function (o, n) {
      var p = P(o.j.b, k), ok = fin(p[0]) && fin(p[1]);
      o.c.style.display = o.lab.style.display = ok ? "" : "none";
      if (!ok) { o.arrow.style.display = "none"; return; }
      var x = X(p[0]), y = Y(p[1]);
      o.x = x; o.y = y;
      o.c.setAttribute("cx", x.toFixed(1)); o.c.setAttribute("cy", y.toFixed(1));
      var fx = S["Fx:" + o.j.name][k], fy = S["Fy:" + o.j.name][k], f = S["F:" + o.j.name][k];
      if (fin(f) && f > bestF) { bestF = f; best = n; }
      var ok2 = setLine(o.arrow, x, y, fx, fy);
      o.arrow.setAttribute("data-f", fin(f) ? f : "");
      o.flab.style.display = ok2 && showForces ? "" : "none";
      o.flab.textContent = o.j.name + " " + fmtS("F:" + o.j.name, f) + " N";
      o.tip = ok2 ? [x + fx * fscale, y - fy * fscale] : null;
    });
    loadArrows.forEach(function (o) {
      var p = P(o.l.at, k), x = X(p[0]), y = Y(p[1]), ok = fin(x) && fin(y);
      if (o.l.kind === "force") {
        var fx = S[o.l.x][k], fy = S[o.l.y][k];
        ok = ok && setLine(o.a, x, y, fx, fy);
        o.t.textContent = o.l.label + " " + fmt(Math.hypot(fx, fy), 4) + " N";
        o.tip = ok ? [x + fx * fscale, y - fy * fscale] : null;
      } else if (o.l.kind === "spring" || o.l.kind === "damper") {
        var q = P(o.l.to, k), x1 = X(q[0]), y1 = Y(q[1]), v = S[o.l.v][k];
        ok = ok && fin(x1) && fin(y1);
        o.a.style.display = ok ? "" : "none";
        if (ok) o.a.setAttribute("d", zigzag(x, y, x1, y1, o.l.kind, o.l.lane));
        o.t.textContent = o.l.label + " " + fmt(v, 4) + " N";
        var Lz = Math.hypot(x1 - x, y1 - y) || 1, off = 14 * (o.l.lane || 0) + 8;
        o.tip = ok ? [0.5 * (x + x1) - (y1 - y) / Lz * off, 0.5 * (y + y1) + (x1 - x) / Lz * off] : null;
      } else {
        var m = S[o.l.m][k];
        ok = ok && fin(m) && m !== 0;
        o.a.style.display = ok ? "" : "none";
        if (ok) o.a.setAttribute("d", arc(x, y, 20, m));
        o.t.textContent = o.l.label + " " + fmt(m, 4) + " N m";
        o.tip = ok ? [x + 20, y - 20] : null;
      }
      o.t.style.display = ok && showForces ? "" : "none";
    });
    drvArrows.forEach(function (o) {
      var v = S[o.d.key][k], ok = o.j && fin(v);
      if (!ok) { o.a.style.display = o.t.style.display = "none"; o.tip = null; return; }
      var p = P(o.j.b, k), x = X(p[0]), y = Y(p[1]);
      if (o.d.unit === "N m") {
        o.a.style.display = v !== 0 ? "" : "none";
        o.a.setAttribute("d", arc(x, y, 17, v));
        o.tip = [x - 17, y - 17];
      } else {  // a driver force along the joint's axis, on its second body
        var ang = o.j.angle ? o.j.angle[k] : 0;
        ok = setLine(o.a, x, y, v * Math.cos(ang), v * Math.sin(ang));
        o.tip = ok ? [x + v * Math.cos(ang) * fscale, y - v * Math.sin(ang) * fscale] : null;
      }
      o.t.textContent = "driver " + o.d.joint + " " + fmtS(o.d.key, v) + " " + o.d.unit;
      o.t.style.display = showForces ? "" : "none";
    });
    if (shake) {
      var sfx = S[G.shaking.fx][k], sfy = S[G.shaking.fy][k], sx0 = X(G.shaking.x), sy0 = Y(G.shaking.y);
      var sok = setLine(shake.a, sx0, sy0, sfx, sfy);
      shake.t.textContent = "shaking " + fmt(Math.hypot(sfx, sfy), 4) + " N";
      shake.t.style.display = sok && showForces ? "" : "none";
      shake.tip = sok ? [sx0 + sfx * fscale, sy0 - sfy * fscale] : null;
    }
    ring.style.display = best >= 0 ? "" : "none";
    if (best >= 0) { ring.setAttribute("cx", joints[best].c.getAttribute("cx")); ring.setAttribute("cy", joints[best].c.getAttribute("cy")); }
    traces.forEach(function (o) {
      var p = P(o.id, k), ok = fin(p[0]) && fin(p[1]);
      o.dot.style.display = o.lab.style.display = ok ? "" : "none";
      if (!ok) return;
      o.dot.setAttribute("cx", X(p[0]).toFixed(1)); o.dot.setAttribute("cy", Y(p[1]).toFixed(1));
      o.x = X(p[0]); o.y = Y(p[1]);
    });
    ics.forEach(function (o) {
      var x = S[o.c.x][k], y = S[o.c.y][k], ok = fin(x) && fin(y);
      if (ok) { o.x = X(x); o.y = Y(y); ok = o.x >= 0 && o.x <= VW && o.y >= 0 && o.y <= VH; }
      o.g.style.display = o.lab.style.display = ok ? "" : "none";
      if (!ok) { o.x = o.y = NaN; return; }
      o.g.setAttribute("transform", "translate(" + o.x.toFixed(1) + "," + o.y.toFixed(1) + ") scale(" + textScale.toFixed(3) + ")");
    });
    // labels: pivots are obstacles; joint names first, then traced points, bodies, forces
    var obst = [], r = 6.5 * textScale;
    joints.forEach(function (o) { if (o.c.style.display !== "none" && fin(o.x)) obst.push([o.x - r, o.y - r, o.x + r, o.y + r]); });
    var items = [];
    if (showLabels) {
      joints.forEach(function (o) { items.push({node: o.lab, x: o.x, y: o.y, fs: 11.5, r: 7}); });
      traces.forEach(function (o) { items.push({node: o.lab, x: o.x, y: o.y, fs: 12, r: 6}); });
      bodies.forEach(function (o) { items.push({node: o.lab, x: o.ax, y: o.ay, fs: 12, r: 6, prefer: o.pref}); });
    }
    if (showICs) ics.forEach(function (o) { items.push({node: o.lab, x: o.x, y: o.y, fs: 11, r: 8}); });
    if (showForces) {
      joints.forEach(function (o) { if (o.tip) items.push({node: o.flab, x: o.tip[0], y: o.tip[1], fs: 11, r: 3}); });
      loadArrows.concat(drvArrows).forEach(function (o) { if (o.tip) items.push({node: o.t, x: o.tip[0], y: o.tip[1], fs: 11, r: 3}); });
      if (shake && shake.tip) items.push({node: shake.t, x: shake.tip[0], y: shake.tip[1], fs: 11, r: 3});
    }
    place(items, obst);
    return best;
  }

  // ------------------------------------------------------------------ info panel
  var elTime = document.getElementById("time"), elFrame = document.getElementById("frameinfo"),
      elDrv = document.getElementById("drivers"), elLoaded = document.getElementById("loaded"),
      elJF = document.getElementById("jointforces");
  var drv = D.drivers.map(function (d) {
    var row = h("div", "drv", elDrv);
    var b = h("b", "", row, d.joint); b.style.color = d.color;
    var eff = h("span", "", row), q = h("span", "sub", row);
    return {d: d, eff: eff, q: q};
  });
  (function () {
    var tr = h("tr", "", h("thead", "", elJF));
    h("th", "", tr, "joint"); h("th", "", tr, "|F| now"); h("th", "", tr, "vs. run peak");
  })();
  var jfBody = h("tbody", "", elJF);
  var jfRows = G.joints.map(function (j) {
    var tr = h("tr", "", jfBody);
    h("th", "", tr, j.name);
    var td = h("td", "num", tr), bar = h("td", "bar", tr), fb = h("span", "fbar", bar);
    return {tr: tr, td: td, bar: fb, name: j.name};
  });
  var Fpeak = G.fmax || 1;
  function drawInfo(k, best) {
    elTime.textContent = "t = " + T[k].toFixed(4) + " s";
    elFrame.textContent = "frame " + (k + 1) + " / " + N + (D.valid[k] ? "" : "  (singular: NaN)");
    drv.forEach(function (o) {
      var q = S[o.d.q] ? S[o.d.q][k] : null;
      o.eff.textContent = " driver " + o.d.word + " " + fmtS(o.d.key, S[o.d.key][k]) + " " + o.d.unit;
      o.q.textContent = q !== null ? "at q = " + fmtS(o.d.q, q) + " " + o.d.qunit : "";
    });
    if (best >= 0) {
      var name = G.joints[best].name;
      elLoaded.innerHTML = "";
      h("span", "", elLoaded, "most loaded joint: ");
      h("span", "hot", elLoaded, name + "  " + fmtS("F:" + name, S["F:" + name][k]) + " N");
    } else elLoaded.textContent = "most loaded joint: –";
    jfRows.forEach(function (o, n) {
      var f = S["F:" + o.name][k];
      o.td.textContent = fmtS("F:" + o.name, f) + " N";
      o.bar.style.width = (fin(f) ? Math.min(100, 100 * f / Fpeak) : 0).toFixed(1) + "%";
      o.tr.className = n === best ? "hot" : "";
    });
  }

  // ------------------------------------------------------------------ plots
  var PW = 360, PH = 210, ML = 50, MR = 16, MT = 22, MB = 32;
  var container = document.getElementById("plots");
  function buildPlots() {
    container.innerHTML = "";
    plots = [];
    var xsT = S[xmode.key], xrT = range([xsT]);
    if (xmode.key === "t") xrT = [T[0], T[N - 1] > T[0] ? T[N - 1] : T[0] + 1];
    var sec = null, grid = null;
    D.plots.forEach(function (spec) {
      // a panel with its own x series (output versus input, a polar load diagram) keeps it
      var xm = spec.x || xmode, xs = spec.x ? S[spec.x.key] : xsT, xr = spec.x ? range([xs]) : xrT;
      var polar = spec.kind === "polar", angleX = spec.x ? !!spec.x.angle : xmode.key !== "t";
      if (spec.section !== sec) {
        sec = spec.section;
        h("h3", "psec", container, sec);
        grid = h("div", "pgrid", container);
      }
      var panel = h("div", "panel", grid);
      var svg = el("svg", {viewBox: "0 0 " + PW + " " + PH}, panel);
      var yr = range(spec.series.map(function (s) { return S[s.key]; }));
      var x0 = ML, x1 = PW - MR, y0 = PH - MB, y1 = MT;
      if (polar) {  // the origin in view and one scale on both axes (N per px alike)
        xr = [Math.min(xr[0], 0), Math.max(xr[1], 0)]; yr = [Math.min(yr[0], 0), Math.max(yr[1], 0)];
        var u = Math.max((xr[1] - xr[0]) / (x1 - x0), (yr[1] - yr[0]) / (y0 - y1)) * 1.1;
        var cxr = (xr[0] + xr[1]) / 2, cyr = (yr[0] + yr[1]) / 2;
        xr = [cxr - u * (x1 - x0) / 2, cxr + u * (x1 - x0) / 2];
        yr = [cyr - u * (y0 - y1) / 2, cyr + u * (y0 - y1) / 2];
      } else {
        var pad = 0.05 * (yr[1] - yr[0]); yr = [yr[0] - pad, yr[1] + pad];
        if (spec.x) { var padx = 0.02 * (xr[1] - xr[0]); xr = [xr[0] - padx, xr[1] + padx]; }
      }
      var sx = function (v) { return x0 + (v - xr[0]) / (xr[1] - xr[0]) * (x1 - x0); };
      var sy = function (v) { return y0 - (v - yr[0]) / (yr[1] - yr[0]) * (y0 - y1); };
      // grid and ticks
      var ys = niceStep(yr[1] - yr[0], 5), v;
      for (v = Math.ceil(yr[0] / ys) * ys; v <= yr[1] + 1e-9 * ys; v += ys) {
        var yy = sy(v);
        el("line", {x1: x0, x2: x1, y1: yy, y2: yy, "class": Math.abs(v) < ys * 1e-6 ? "zero" : "gridl"}, svg);
        el("text", {x: x0 - 4, y: yy + 3.5, "text-anchor": "end", "class": "tick"}, svg).textContent = tickText(v, ys);
      }
      var xst = niceStep(xr[1] - xr[0], 6);
      if (angleX) {  // an angle in degrees: ticks on 15, 30, 45, 90... multiples
        var dstep = [5, 10, 15, 30, 45, 90, 180, 360, 720, 1440].filter(function (d) { return d >= (xr[1] - xr[0]) / 8; })[0];
        if (dstep) xst = dstep;
      }
      for (v = Math.ceil(xr[0] / xst) * xst; v <= xr[1] + 1e-9 * xst; v += xst) {
        var xx = sx(v);
        el("line", {x1: xx, x2: xx, y1: y0, y2: y1, "class": polar && Math.abs(v) < xst * 1e-6 ? "zero" : "gridl"}, svg);
        el("line", {x1: xx, x2: xx, y1: y0, y2: y0 + 4, "class": "axis"}, svg);
        el("text", {x: xx, y: y0 + 15, "text-anchor": "middle", "class": "tick"}, svg).textContent = tickText(v, xst);
      }
      el("line", {x1: x0, x2: x0, y1: y0, y2: y1, "class": "axis"}, svg);
      el("line", {x1: x0, x2: x1, y1: y0, y2: y0, "class": "axis"}, svg);
      el("text", {x: x1, y: PH - 3, "text-anchor": "end", "class": "tick"}, svg).textContent = xm.label;
      if (polar) el("text", {x: x0 + 4, y: y1 + 10, "class": "tick"}, svg).textContent = "↑ " + spec.series[0].label + " (" + spec.unit + ")";
      el("text", {x: 6, y: 14, "class": "ptitle"}, svg).textContent = spec.title + (spec.unit ? "  (" + spec.unit + ")" : "");
      // series
      spec.series.forEach(function (s) {
        var ya = S[s.key], d = "", pen = false;
        for (var k = 0; k < N; k++) {
          if (fin(ya[k]) && fin(xs[k])) { d += (pen ? "L" : "M") + sx(xs[k]).toFixed(1) + "," + sy(ya[k]).toFixed(1); pen = true; }
          else pen = false;
        }
        el("path", {d: d, "class": "series", stroke: s.color}, svg);
      });
      // the cursor: a vertical line, or on a polar diagram the force vector from the origin
      var cursor = el("line", {"class": "cursor", x1: x0, x2: x0, y1: y0, y2: y1}, svg);
      if (polar) cursor.setAttribute("class", "cursor polar");
      var dots = spec.series.map(function (s) { return el("circle", {r: 3, fill: s.color, stroke: "#fff", "stroke-width": 1}, svg); });
      var leg = h("div", "legend", panel);
      var vals = spec.series.map(function (s) {
        var it = h("span", "", leg), sw = h("i", "", it); sw.style.background = s.color;
        h("span", "", it, s.label);
        return h("b", "", it, "");
      });
      var xval = null;
      if (spec.x) { var xit = h("span", "", leg); h("span", "", xit, spec.x.short || xm.label); xval = h("b", "", xit, ""); }
      var hover = el("line", {"class": "hoverline", x1: x0, x2: x0, y1: y0, y2: y1}, svg);
      hover.style.display = "none";
      var hit = el("rect", {x: x0, y: y1, width: x1 - x0, height: y0 - y1, fill: "transparent"}, svg);
      var at = function (e) {
        var r = svg.getBoundingClientRect(), vx = (e.clientX - r.left) / r.width * PW;
        var xv = xr[0] + (vx - x0) / (x1 - x0) * (xr[1] - xr[0]);
        if (polar) {  // the sample whose point is nearest the pointer
          var vy = (e.clientY - r.top) / r.height * PH, ya = S[spec.series[0].key], best = 0, bd = Infinity;
          for (var i = 0; i < N; i++) {
            if (!fin(xs[i]) || !fin(ya[i])) continue;
            var dd = Math.pow(sx(xs[i]) - vx, 2) + Math.pow(sy(ya[i]) - vy, 2);
            if (dd < bd) { bd = dd; best = i; }
          }
          return best;
        }
        return xm.key === "t" ? lowerBound(T, xv) : nearest(xs, xv);
      };
      var pick = function (e) { pause(); setFrame(at(e)); };
      // hover: a readout of every series at the frame under the pointer (the cursor stays)
      var readout = function (e) {
        var k = at(e), x = xs[k];
        hover.style.display = fin(x) && !polar ? "" : "none";
        if (fin(x)) { hover.setAttribute("x1", sx(x).toFixed(1)); hover.setAttribute("x2", sx(x).toFixed(1)); }
        tip.innerHTML = "";
        tip.setAttribute("data-frame", String(k));
        h("div", "tt", tip, "t = " + fmt(T[k], 5) + " s" + (xm.key === "t" ? "" : ", " + xm.label.replace(/ \(.*\)$/, "") + " = " + fmtS(xm.key, x) + (polar ? " " + spec.unit : "")));
        spec.series.forEach(function (s) {
          var row = h("div", "tr", tip), sw = h("i", "", row); sw.style.background = s.color;
          h("span", "", row, s.label + " ");
          var b = h("b", "", row, fmtS(s.key, S[s.key][k]) + (spec.unit ? " " + spec.unit : ""));
          b.setAttribute("data-key", s.key);
        });
        LD.placeTip(tip, panel, e);
      };
      var tip = h("div", "tooltip", panel);
      var down = false;
      hit.addEventListener("pointerdown", function (e) { down = true; try { hit.setPointerCapture(e.pointerId); } catch (err) {} pick(e); });
      hit.addEventListener("pointermove", function (e) { if (down) pick(e); readout(e); });
      hit.addEventListener("pointerup", function () { down = false; });
      hit.addEventListener("pointerleave", function () { tip.style.display = "none"; hover.style.display = "none"; });
      exportButtons(panel, spec, svg);
      plots.push({spec: spec, svg: svg, sx: sx, sy: sy, xs: xs, cursor: cursor, dots: dots, vals: vals, xval: xval, polar: polar, y0: y0, y1: y1});
    });
  }
  // export: a panel's series as CSV (every page frame), the panel as SVG or PNG
  function download(name, blob) {
    var a = document.createElement("a");
    a.href = URL.createObjectURL(blob); a.download = name;
    document.body.appendChild(a); a.click(); a.remove();
    setTimeout(function () { URL.revokeObjectURL(a.href); }, 1000);
  }
  function slug(s) { return s.replace(/[^A-Za-z0-9]+/g, "_").replace(/^_|_$/g, "").toLowerCase(); }
  function panelCSV(spec) {
    // a panel with its own x series (spec.x) exports it after t
    var xcol = spec.x ? [spec.x] : [];
    var head = ["t_s"].concat(xcol.map(function (x) { return x.label; }), spec.series.map(function (s) { return s.label + (spec.unit ? " (" + spec.unit + ")" : ""); }));
    var lines = [head.map(function (c) { return '"' + c.replace(/"/g, '""') + '"'; }).join(",")];
    for (var k = 0; k < N; k++)
      lines.push([T[k]].concat(xcol.concat(spec.series).map(function (s) { var v = S[s.key][k]; return fin(v) ? v : ""; })).join(","));
    return lines.join("\n") + "\n";
  }
  function panelSVG(svg) {
    var c = svg.cloneNode(true);
    c.setAttribute("xmlns", NS); c.setAttribute("width", PW); c.setAttribute("height", PH);
    var st = document.createElementNS(NS, "style");
    st.textContent = "text{font-family:DejaVu Sans,Helvetica,Arial,sans-serif}.ptitle{font-size:12.5px;font-weight:bold}" +
      ".tick{font-size:10.5px;fill:#444}.axis{stroke:#888}.gridl{stroke:#eceff2}.zero{stroke:#b9c0c7}" +
      ".cursor{stroke:#c62828;stroke-width:1.3}.hoverline{display:none}.series{fill:none;stroke-width:1.6}";
    c.insertBefore(st, c.firstChild);
    var bg = document.createElementNS(NS, "rect");
    bg.setAttribute("width", PW); bg.setAttribute("height", PH); bg.setAttribute("fill", "#fff");
    c.insertBefore(bg, st.nextSibling);
    return new XMLSerializer().serializeToString(c);
  }
  function exportButtons(panel, spec, svg) {
    var bar = h("div", "pexport", panel), name = slug(spec.title);
    var b1 = h("button", "", bar, "CSV"); b1.type = "button"; b1.title = "the panel's series as CSV";
    b1.addEventListener("click", function () { download(name + ".csv", new Blob([panelCSV(spec)], {type: "text/csv"})); });
    var b2 = h("button", "", bar, "SVG"); b2.type = "button";
    b2.addEventListener("click", function () { download(name + ".svg", new Blob([panelSVG(svg)], {type: "image/svg+xml"})); });
    var b3 = h("button", "", bar, "PNG"); b3.type = "button";
    b3.addEventListener("click", function () {
      var img = new Image(), url = URL.createObjectURL(new Blob([panelSVG(svg)], {type: "image/svg+xml"}));
      img.onload = function () {
        var cv = document.createElement("canvas"); cv.width = PW * 2; cv.height = PH * 2;
        var cx = cv.getContext("2d"); cx.scale(2, 2); cx.drawImage(img, 0, 0);
        URL.revokeObjectURL(url);
        cv.toBlob(function (blob) { download(name + ".png", blob); }, "image/png");
      };
      img.src = url;
    });
  }
  window.__linkdynExport = {csv: function (n) { return panelCSV(D.plots[n]); },
                            svg: function (n) { return panelSVG(plots[n].svg); }};

  function drawPlots(k) {
    plots.forEach(function (p) {
      var x = p.xs[k], cx = fin(x) ? p.sx(x).toFixed(1) : -10;
      if (p.polar) {  // the force vector: from the origin to the current point
        var py = S[p.spec.series[0].key][k], okp = fin(x) && fin(py);
        p.cursor.style.display = okp ? "" : "none";
        if (okp) {
          p.cursor.setAttribute("x1", p.sx(0).toFixed(1)); p.cursor.setAttribute("y1", p.sy(0).toFixed(1));
          p.cursor.setAttribute("x2", cx); p.cursor.setAttribute("y2", p.sy(py).toFixed(1));
        }
      } else { p.cursor.setAttribute("x1", cx); p.cursor.setAttribute("x2", cx); }
      if (p.xval) p.xval.textContent = fmtS(p.spec.x.key, x);
      p.spec.series.forEach(function (s, n) {
        var y = S[s.key][k], ok = fin(y) && fin(x);
        p.dots[n].style.display = ok ? "" : "none";
        if (ok) { p.dots[n].setAttribute("cx", cx); p.dots[n].setAttribute("cy", p.sy(y).toFixed(1)); }
        p.vals[n].textContent = fmtS(s.key, y);
      });
    });
  }

  // ------------------------------------------------------------------ state and controls
  var btnPlay = document.getElementById("play"), scrub = document.getElementById("scrubber"),
      selSpeed = document.getElementById("speed"), selX = document.getElementById("xaxis");
  scrub.max = String(N - 1);
  var span = T[N - 1] - T[0];
  // 1x is real time, unless a run is so short or so long that it could not be followed
  var rate = span > 0 ? span / Math.min(Math.max(span, 1), 30) : 1;  // simulated s per real s
  document.getElementById("ratenote").textContent =
    Math.abs(rate - 1) < 1e-9 ? "1× = real time" : "1× shows the run in " + fmt(span / rate, 2) + " s";

  function setFrame(k, fromScrub) {
    k = Math.max(0, Math.min(N - 1, k | 0));
    frame = k;
    window.__linkdynFrame = k;
    var best = drawAnim(k);
    drawPlots(k);
    drawInfo(k, best);
    if (!fromScrub) scrub.value = String(k);
    if (!playing) { simT = T[k]; keepHash(); }
  }
  function tick(now) {
    if (!playing) return;
    if (last !== null && span > 0) {
      var inc = (now - last) / 1000 * speed * rate;
      simT += inc;
      window.__linkdynPlayed += inc;  // simulated seconds played in all, for tests
      window.__linkdynTick = now;     // the frame time that total belongs to
      if (simT > T[N - 1]) simT = T[0] + ((simT - T[0]) % span);
    }
    last = now;
    setFrame(span > 0 ? lowerBound(T, simT) : (frame + 1) % N);
    requestAnimationFrame(tick);
  }
  function play() {
    if (playing) return;
    playing = true; last = null; simT = T[frame];
    if (frame >= N - 1) simT = T[0];
    btnPlay.textContent = "❚❚ Pause";
    requestAnimationFrame(tick);
  }
  function pause() { var was = playing; playing = false; btnPlay.textContent = "▶ Play"; if (was) keepHash(); }
  btnPlay.addEventListener("click", function () { if (playing) pause(); else play(); });
  document.getElementById("step").addEventListener("click", function () { pause(); setFrame(frame + 1); });
  document.getElementById("stepback").addEventListener("click", function () { pause(); setFrame(frame - 1); });
  scrub.addEventListener("input", function () { pause(); setFrame(parseInt(scrub.value, 10), true); });
  selSpeed.addEventListener("change", function () { speed = parseFloat(selSpeed.value) || 1; });
  speed = parseFloat(selSpeed.value) || 1;
  D.xaxes.forEach(function (a, n) {
    var o = document.createElement("option"); o.value = String(n); o.textContent = a.label; selX.appendChild(o);
  });
  selX.addEventListener("change", function () { xmode = D.xaxes[parseInt(selX.value, 10)]; buildPlots(); drawPlots(frame); });
  document.getElementById("show-labels").addEventListener("change", function (e) { showLabels = e.target.checked; gLabels.style.display = showLabels ? "" : "none"; setFrame(frame); });
  document.getElementById("show-traces").addEventListener("change", function (e) { gTraces.style.display = e.target.checked ? "" : "none"; });
  document.getElementById("show-forces").addEventListener("change", function (e) {
    showForces = e.target.checked;
    gForces.style.display = gFLabels.style.display = showForces ? "" : "none";
    setFrame(frame);
  });
  document.getElementById("show-ics").addEventListener("change", function (e) {
    showICs = e.target.checked;
    gIC.style.display = gICLabels.style.display = showICs ? "" : "none";
    setFrame(frame);
  });
  window.addEventListener("resize", function () { updateTextScale(); setFrame(frame); });
  updateTextScale();
  document.addEventListener("keydown", function (e) {
    var tag = (e.target && e.target.tagName) || "";
    if (tag === "INPUT" || tag === "SELECT" || tag === "BUTTON") return;
    if (e.key === " ") { e.preventDefault(); if (playing) pause(); else play(); }
    else if (e.key === "ArrowRight") { pause(); setFrame(frame + 1); }
    else if (e.key === "ArrowLeft") { pause(); setFrame(frame - 1); }
  });

  // key results: a click shows that instant
  Array.prototype.forEach.call(document.querySelectorAll(".keyitem[data-frame]"), function (b) {
    b.addEventListener("click", function () {
      pause(); setFrame(parseInt(b.getAttribute("data-frame"), 10));
      var box = document.querySelector(".animbox").getBoundingClientRect();
      if (box.bottom < 0 || box.top > window.innerHeight) document.querySelector(".animbox").scrollIntoView({block: "start"});
    });
  });
  if (D.zero && D.zero.length) {
    var zn = h("p", "note", document.getElementById("plots"));
    zn.textContent = "Not plotted, zero to rounding (below 1e-12 of their scale): " + D.zero.join("; ") + ".";
  }

  // the frame is kept in the page address (#frame=K), so a link or a reload shows that instant
  function frameFromHash() {
    var m = /(?:^#|&)frame=(\d+)/.exec(location.hash);
    return m ? Math.max(0, Math.min(N - 1, parseInt(m[1], 10))) : null;
  }
  var hashTimer = null;
  function keepHash() {
    if (playing) return;
    clearTimeout(hashTimer);
    hashTimer = setTimeout(function () {
      try { history.replaceState(null, "", "#frame=" + frame); } catch (err) { /* file: in some browsers */ }
    }, 150);
  }
  window.addEventListener("hashchange", function () { var k = frameFromHash(); if (k !== null && k !== frame) { pause(); setFrame(k); } });

  buildPlots();
  var k0 = frameFromHash();
  setFrame(k0 === null ? 0 : k0);
})();
