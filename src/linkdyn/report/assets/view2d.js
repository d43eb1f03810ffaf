/* linkdyn report: the planar view of the mechanism, one SVG in the page's #anim, drawn at a
   frame. LD.view2d(D, anim, fmtS) returns {draw(k) -> the most loaded joint's index,
   resize(), show(what, on)}: report.js picks it (or LD.view3d) by the data's dimension. */
LD.view2d = function (D, anim, fmtS) {
  "use strict";
  var S = D.series, G = D.geom, T = D.t, N = T.length;
  var el = LD.el, fin = LD.fin, fmt = LD.fmt;
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
  el("path", {d: "M0,0 L10,5 L0,10 z", fill: LD.FORCE.joint}, mk);
  [["arrow-load", LD.FORCE.load], ["arrow-shake", LD.FORCE.shaking], ["arrow-drv", LD.FORCE.driver]].forEach(function (m) {
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
    node.setAttribute("class", "body"); node.setAttribute("data-body", b.name);
    var lab = el("text", {"font-size": 12, fill: b.color, "text-anchor": "middle", "font-style": "italic"}, gLabels);
    lab.textContent = b.name;
    return {b: b, node: node, lab: lab};
  });

  // sliders (prismatic joints): a block along the axis at the second body's point; slots: the
  // first body's slot, an outline along the axis around the pin
  var sliders = G.joints.filter(function (j) { return j.kind === "prismatic" || j.kind === "slot"; }).map(function (j) {
    var slot = j.kind === "slot";
    var body = G.bodies.filter(function (b) { return b.name === (slot ? j.first : j.second); })[0];
    var color = body ? body.color : "#888", g = el("g", {"class": "slider"}, gSliders);
    el("rect", slot ? {x: -26, y: -7, width: 52, height: 14, rx: 7, fill: "none", stroke: color,
                       "stroke-width": 3}
                    : {x: -18, y: -9, width: 36, height: 18, rx: 2, fill: color,
                       "fill-opacity": 0.85, stroke: "#333", "stroke-width": 1.5}, g);
    return {j: j, g: g};
  });

  // joints
  // a force label placed at the view's edge is joined to its arrow by a thin leader line
  var leaders = [];
  function leader(color) {
    var l = el("line", {stroke: color, "stroke-dasharray": "3 2", "class": "leader"}, gFLabels);
    l.style.display = "none";
    leaders.push(l);
    return l;
  }
  var joints = G.joints.map(function (j) {
    var c = j.kind === "revolute" ? el("circle", {r: 5.5, fill: "#fff", stroke: "#222", "stroke-width": 2}, gJoints)
                                  : el("circle", {r: 3, fill: "#222"}, gJoints);
    var lab = el("text", {"font-size": 11.5, fill: "#222"}, gLabels);
    lab.textContent = j.name;
    var arrow = el("line", {stroke: LD.FORCE.joint, "stroke-width": 2.2, "marker-end": "url(#arrowhead)",
                            "class": "farrow", "data-joint": j.name}, gForces);
    var flab = el("text", {"font-size": 11, fill: LD.FORCE.joint}, gFLabels);
    return {j: j, c: c, lab: lab, arrow: arrow, flab: flab, leader: leader(LD.FORCE.joint)};
  });
  var ring = el("circle", {r: 11, fill: "none", stroke: LD.FORCE.joint, "stroke-width": 2.5}, gJoints);

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

  // an arrow from the view's edge towards a point off it, (dx, dy) in view units (y down)
  function pointer(dx, dy) {
    var a = Math.atan2(-dy, dx) * 180 / Math.PI, arrows = ["→", "↗", "↑", "↖", "←", "↙", "↓", "↘"];
    return arrows[((Math.round(a / 45) % 8) + 8) % 8];
  }

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
    el("line", {x1: lx0, y1: ly, x2: lx1, y2: ly, stroke: LD.FORCE.joint, "stroke-width": 2.2, "marker-end": "url(#arrowhead)"}, fleg);
    el("text", {x: lx0 - 6, y: ly + 4, "text-anchor": "end", "font-size": 12, fill: LD.FORCE.joint, "class": "legtext"}, fleg).textContent =
      "force scale: " + fmt(Fr, 3) + " N";
  }
  window.__linkdynForces = {scale: fscale};
  // external loads, the driver efforts and the shaking force on the frame
  var loadArrows = (G.loads || []).map(function (l) {
    var line = l.kind === "spring" || l.kind === "damper";
    // springs and dampers are part of the drawing (below the bodies' joints), their tension a label
    var a = l.kind === "force" ? el("line", {stroke: LD.FORCE.load, "stroke-width": 2.2, "marker-end": "url(#arrow-load)", "class": "farrow"}, gForces)
          : line ? el("path", {fill: "none", stroke: "#455a64", "stroke-width": 1.6, "class": "f" + l.kind, "data-load": l.label}, gSliders)
          : el("path", {fill: "none", stroke: LD.FORCE.load, "stroke-width": 2, "marker-end": "url(#arrow-load)", "class": "ftorque"}, gForces);
    var t = el("text", {"font-size": 11, fill: LD.FORCE.load}, gFLabels);
    return {l: l, a: a, t: t, leader: leader(LD.FORCE.load)};
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
    var a = d.unit === "N m" ? el("path", {fill: "none", stroke: LD.FORCE.driver, "stroke-width": 2.4, "marker-end": "url(#arrow-drv)"}, gForces)
                             : el("line", {stroke: LD.FORCE.driver, "stroke-width": 2.4, "marker-end": "url(#arrow-drv)", "class": "farrow"}, gForces);
    var t = el("text", {"font-size": 11, fill: LD.FORCE.driver}, gFLabels);
    return {d: d, j: j, a: a, t: t, leader: leader(LD.FORCE.driver)};
  });
  var shake = G.shaking ? {a: el("line", {stroke: LD.FORCE.shaking, "stroke-width": 2.4, "marker-end": "url(#arrow-shake)", "class": "farrow"}, gForces),
                           t: el("text", {"font-size": 11, fill: LD.FORCE.shaking}, gFLabels), leader: leader(LD.FORCE.shaking)} : null;
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
  // clear of each other and of the pivots (LD.placer, common.js); sizes in screen pixels
  // whatever the zoom
  var textScale = 1;
  function updateTextScale() {
    var w = anim.getBoundingClientRect().width;
    textScale = w > 0 ? Math.max(1, VW / w) : 1;
    // the scale bars' texts: 12 px on the screen whatever the zoom
    Array.prototype.forEach.call(anim.querySelectorAll(".legtext"), function (t) {
      t.setAttribute("font-size", (12 * textScale).toFixed(1));
    });
  }
  var place = LD.placer(VW, VH);

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
      var x = S[o.c.x][k], y = S[o.c.y][k], ok = fin(x) && fin(y), inside = false;
      o.off = false;
      if (ok) { o.x = X(x); o.y = Y(y); inside = o.x >= 0 && o.x <= VW && o.y >= 0 && o.y <= VH; }
      o.g.style.display = inside ? "" : "none";
      o.lab.style.display = ok ? "" : "none";
      if (!ok) { o.x = o.y = NaN; return; }
      if (!inside) {
        // a centre outside the view: its label at the view's edge, pointing to it, says so
        var m = 14 * textScale, cx = Math.min(Math.max(o.x, m), VW - m), cy = Math.min(Math.max(o.y, m), VH - m);
        o.lab.textContent = "I " + o.c.body + " off view " + pointer(o.x - cx, o.y - cy);
        o.x = cx; o.y = cy; o.off = true;
        return;
      }
      o.lab.textContent = "I " + o.c.body;
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
    // a centre off the view is said at the edge whatever the room (o.off), first
    if (showICs) ics.forEach(function (o) { if (o.off) items.unshift({node: o.lab, x: o.x, y: o.y, fs: 11, r: 8, must: true}); });
    if (showICs) ics.forEach(function (o) { if (!o.off) items.push({node: o.lab, x: o.x, y: o.y, fs: 11, r: 8}); });
    leaders.forEach(function (l) { l.style.display = "none"; });
    if (showForces) {
      // a force's label never drops out: with no room by its arrow's tip, at the view's edge
      joints.forEach(function (o) { if (o.tip) items.push({node: o.flab, x: o.tip[0], y: o.tip[1], fs: 11, r: 3, edge: true, leader: o.leader}); });
      loadArrows.concat(drvArrows).forEach(function (o) { if (o.tip) items.push({node: o.t, x: o.tip[0], y: o.tip[1], fs: 11, r: 3, edge: true, leader: o.leader}); });
      if (shake && shake.tip) items.push({node: shake.t, x: shake.tip[0], y: shake.tip[1], fs: 11, r: 3, edge: true, leader: shake.leader});
    }
    // the bodies as drawn at this frame (bars, plates, dots, slider blocks): a force's label
    // keeps clear of them (LD.placer)
    var shapes = [];
    bodies.forEach(function (o) {
      if (o.node.style.display === "none") return;
      var pts = o.b.outline.map(function (id) { var p = P(id, k); return [X(p[0]), Y(p[1])]; });
      if (o.b.shape === "polygon") shapes.push({pts: pts, r: 2, closed: true});
      else if (o.b.shape === "dot") shapes.push({pts: pts.slice(0, 1), r: 6});
      else shapes.push({pts: [pts[0], pts[pts.length - 1]], r: 4.5});
    });
    sliders.forEach(function (o) {
      if (o.g.style.display === "none") return;
      var p = P(o.j.b, k), a = -o.j.angle[k], c = Math.cos(a), s = Math.sin(a), x = X(p[0]), y = Y(p[1]);
      var hw = o.j.kind === "slot" ? 27.5 : 19, hh = o.j.kind === "slot" ? 8.5 : 10;
      shapes.push({pts: [[-hw, -hh], [hw, -hh], [hw, hh], [-hw, hh]].map(function (q) {
        return [x + c * q[0] - s * q[1], y + s * q[0] + c * q[1]]; }), r: 0.5, closed: true});
    });
    place(items, obst, textScale, shapes);
    return best;
  }

  // the toggles of the page: labels, traced points, forces, instant centres
  function show(what, on) {
    if (what === "labels") { showLabels = on; gLabels.style.display = on ? "" : "none"; }
    else if (what === "traces") gTraces.style.display = on ? "" : "none";
    else if (what === "forces") { showForces = on; gForces.style.display = gFLabels.style.display = on ? "" : "none"; }
    else if (what === "ics") { showICs = on; gIC.style.display = gICLabels.style.display = on ? "" : "none"; }
  }
  return {draw: drawAnim, resize: updateTextScale, show: show, toggles: ["labels", "traces", "forces", "ics"]};
};
