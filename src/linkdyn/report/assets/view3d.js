/* linkdyn report: the 3-D view of a spatial mechanism, one SVG in the page's #anim, drawn at a
   frame by an orthographic camera the user turns (drag), zooms (wheel, pinch) and resets.
   LD.view3d(D, anim, fmtS) returns the interface of LD.view2d: {draw(k) -> the most loaded
   joint's index, resize(), show(what, on), toggles}. No library: the projection is below.

   Camera (window.__linkdynCamera, read by the tests): azimuth az and elevation el (rad) of
   the eye about the bounding sphere's centre c, z up. With
     r = (-sin az, cos az, 0)                      screen right
     u = (-sin el cos az, -sin el sin az, cos el)  screen up
     d = (cos el cos az, cos el sin az, sin el)    towards the eye (depth)
   a point p is drawn at X = cx + s (p - c) . r, Y = cy - s (p - c) . u (viewBox units), with
   s = fit * zoom and fit the scale at which the sphere fills the view. */
LD.view3d = function (D, anim, fmtS) {
  "use strict";
  var S = D.series, G = D.geom, N = D.t.length;
  var el = LD.el, fin = LD.fin, fmt = LD.fmt, DEG = Math.PI / 180;
  var VW = 640, VH = 520;
  anim.setAttribute("viewBox", "0 0 " + VW + " " + VH);
  anim.style.touchAction = "none";    // drags turn the view (the page scrolls elsewhere)
  anim.style.cursor = "grab";
  var home = G.home || {az: -60, el: 25};
  var cam = {az: home.az * DEG, el: home.el * DEG, zoom: 1, centre: G.centre,
             fit: 0.5 * Math.min(VW, VH) / G.radius, cx: VW / 2, cy: VH / 2};
  window.__linkdynCamera = cam;
  var R, U, Dp;   // the camera's axes, set by axes()
  function axes() {
    var ca = Math.cos(cam.az), sa = Math.sin(cam.az), ce = Math.cos(cam.el), se = Math.sin(cam.el);
    R = [-sa, ca, 0]; U = [-se * ca, -se * sa, ce]; Dp = [ce * ca, ce * sa, se];
  }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  // a point (m, global) on the view: [X, Y, depth]
  function proj(p) {
    var q = [p[0] - cam.centre[0], p[1] - cam.centre[1], p[2] - cam.centre[2]], s = cam.fit * cam.zoom;
    return [cam.cx + s * dot(q, R), cam.cy - s * dot(q, U), dot(q, Dp)];
  }
  function P(id, k) {   // a named point at frame k (m, global)
    var p = G.points[id];
    return p.static ? [p.x, p.y, p.z] : [p.x[k], p.y[k], p.z[k]];
  }
  function vec(keys, k) { return [S[keys[0]][k], S[keys[1]][k], S[keys[2]][k]]; }
  function ok3(p) { return fin(p[0]) && fin(p[1]) && fin(p[2]); }
  function add(a, b, f) { return [a[0] + f * b[0], a[1] + f * b[1], a[2] + f * b[2]]; }
  function xy(s) { return s[0].toFixed(1) + "," + s[1].toFixed(1); }
  function bodyOf(name) { return G.bodies.filter(function (b) { return b.name === name; })[0]; }

  // ------------------------------------------------------------------ markers and layers
  var defs = el("defs", {}, anim);
  [["arrow3-r", LD.FORCE.joint], ["arrow3-l", LD.FORCE.load], ["arrow3-d", LD.FORCE.driver]].forEach(function (m) {
    var k = el("marker", {id: m[0], viewBox: "0 0 10 10", refX: 9, refY: 5, markerWidth: 7,
                          markerHeight: 7, orient: "auto-start-reverse"}, defs);
    el("path", {d: "M0,0 L10,5 L0,10 z", fill: m[1]}, k);
  });
  var ball = el("radialGradient", {id: "ball3", cx: "35%", cy: "35%", r: "65%"}, defs);
  el("stop", {offset: "0%", "stop-color": "#ffffff"}, ball);
  el("stop", {offset: "100%", "stop-color": "#555b61"}, ball);
  var gFloor = el("g", {"class": "floor"}, anim), gGround = el("g", {}, anim),
      gTraces = el("g", {}, anim), gBodies = el("g", {}, anim), gJoints = el("g", {}, anim),
      gForces = el("g", {"class": "forces"}, anim), gLabels = el("g", {"class": "labels"}, anim),
      gFLabels = el("g", {"class": "labels flabels"}, anim), gHud = el("g", {"class": "hud"}, anim);
  gForces.style.display = gFLabels.style.display = "none";
  var showForces = false, showLabels = true, place = LD.placer(VW, VH);

  // the floor: a grid of round spacing in the plane z = lowest point, under the mechanism
  var zmin = Infinity;
  Object.keys(G.points).forEach(function (id) {
    var p = G.points[id], zs = p.static ? [p.z] : p.z;
    zs.forEach(function (z) { if (fin(z) && z < zmin) zmin = z; });
  });
  var span = 2.4 * G.radius, mag = Math.pow(10, Math.floor(Math.log10(span / 6)));
  var step = [1, 2, 5, 10].map(function (f) { return f * mag; }).filter(function (v) { return v >= span / 10; })[0] || mag;
  var grid = [], gx0 = Math.floor((cam.centre[0] - span / 2) / step) * step,
      gy0 = Math.floor((cam.centre[1] - span / 2) / step) * step, ng = Math.ceil(span / step) + 1;
  for (var i = 0; i <= ng; i++) {
    grid.push([[gx0 + i * step, gy0, zmin], [gx0 + i * step, gy0 + ng * step, zmin]]);
    grid.push([[gx0, gy0 + i * step, zmin], [gx0 + ng * step, gy0 + i * step, zmin]]);
  }
  var gridPath = el("path", {fill: "none", stroke: "#dde2e7", "stroke-width": 1}, gFloor);
  // the global axes at the origin (x red, y green, z blue), a tenth of the sphere long
  var AX = [["x", [1, 0, 0], "#d62728"], ["y", [0, 1, 0], "#2ca02c"], ["z", [0, 0, 1], "#1f77b4"]];
  var originAxes = AX.map(function (a) {
    return {a: a, line: el("line", {stroke: a[2], "stroke-width": 1.5, opacity: 0.8}, gFloor),
            t: el("text", {"font-size": 11, fill: a[2]}, gFloor)};
  });
  originAxes.forEach(function (o) { o.t.textContent = o.a[0]; });

  // ground: the fixed points joints use, joined by a dashed line, each on a grey base
  var groundLine = G.ground.length > 1 ? el("path", {fill: "none", stroke: "#9aa3ab", "stroke-width": 2,
                                                      "stroke-dasharray": "6 5"}, gGround) : null;
  var bases = G.ground.map(function () {
    return el("path", {fill: "#e9ecef", stroke: "#555", "stroke-width": 1.5}, gGround);
  });

  // traced points: the whole path, faint, and a dot at the frame
  var traces = G.traces.map(function (id) {
    var b = G.bodies.filter(function (x) { return x.points.indexOf(id) >= 0; })[0], c = b ? b.color : "#555";
    return {id: id, path: el("path", {fill: "none", stroke: c, "stroke-width": 1.6, opacity: 0.45}, gTraces),
            dot: el("circle", {r: 4, fill: c, stroke: "#fff", "stroke-width": 1.2}, gTraces)};
  });

  // bodies: their points joined, as the planar view draws them; springs and dampers as lines
  var bodies = G.bodies.map(function (b) {
    var node = b.shape === "polygon"
      ? el("polygon", {fill: b.color, "fill-opacity": 0.35, stroke: b.color, "stroke-width": 4, "stroke-linejoin": "round"}, gBodies)
      : b.shape === "dot" ? el("circle", {r: 6, fill: b.color}, gBodies)
      : el("polyline", {fill: "none", stroke: b.color, "stroke-width": 8, "stroke-linecap": "round",
                        "stroke-linejoin": "round", opacity: 0.9}, gBodies);
    node.setAttribute("data-body", b.name); node.setAttribute("class", "body");
    var lab = el("text", {"font-size": 12, fill: b.color, "font-style": "italic", "text-anchor": "middle"}, gLabels);
    lab.textContent = b.name;
    return {b: b, node: node, lab: lab};
  });
  var springs = (G.springs || []).map(function (s) {
    return {s: s, node: el("line", {stroke: "#455a64", "stroke-width": 1.6, "stroke-dasharray": s.kind === "spring" ? "3 2" : "",
                                    "data-load": s.label}, gBodies)};
  });

  // joints, marked by kind: revolute a pin along its axis, prismatic a block on its axis,
  // cylindrical a sleeve, universal its two crossed axes, spherical a ball; circle.jc is the
  // joint's point (the second body's), where its reaction acts
  var joints = G.joints.map(function (j) {
    var g = el("g", {"class": "joint", "data-joint": j.name, "data-kind": j.kind}, gJoints), parts = {};
    var second = bodyOf(j.second), color = second ? second.color : "#888";
    if (j.kind === "revolute" || j.kind === "cylindrical")
      parts.pin = el("line", {stroke: "#37474f", "stroke-width": j.kind === "revolute" ? 7 : 4, "stroke-linecap": "butt"}, g);
    if (j.kind === "cylindrical") parts.sleeve = el("line", {"class": "block", stroke: color, "stroke-width": 11, opacity: 0.8}, g);
    if (j.kind === "prismatic") {
      parts.rail = el("line", {stroke: "#9aa3ab", "stroke-width": 2, "stroke-dasharray": "5 4"}, g);
      parts.block = el("line", {"class": "block", stroke: color, "stroke-width": 14, opacity: 0.9}, g);
    }
    if (j.kind === "universal") {
      parts.cross1 = el("line", {stroke: "#37474f", "stroke-width": 4, "stroke-linecap": "round"}, g);
      parts.cross2 = el("line", {stroke: "#78909c", "stroke-width": 4, "stroke-linecap": "round"}, g);
    }
    var c = j.kind === "spherical" ? el("circle", {"class": "jc", r: 7, fill: "url(#ball3)", stroke: "#333", "stroke-width": 1}, g)
          : el("circle", {"class": "jc", r: j.kind === "prismatic" ? 3 : 4.5, fill: "#fff", stroke: "#222", "stroke-width": 2}, g);
    var lab = el("text", {"font-size": 11.5, fill: "#222"}, gLabels);
    lab.textContent = j.name;
    var arrow = el("line", {stroke: LD.FORCE.joint, "stroke-width": 2.2, "marker-end": "url(#arrow3-r)",
                            "class": "farrow", "data-joint": j.name}, gForces);
    var flab = el("text", {"font-size": 11, fill: LD.FORCE.joint}, gFLabels);
    return {j: j, g: g, c: c, parts: parts, lab: lab, arrow: arrow, flab: flab};
  });
  var ring = el("circle", {r: 11, fill: "none", stroke: LD.FORCE.joint, "stroke-width": 2.5}, gJoints);
  var Lpin = 0.09 * G.radius;   // half length of a pin or a cross arm, m

  // ------------------------------------------------------------------ forces
  // one length per newton (m / N) for every arrow, drawn in space and projected: the largest
  // force of the frames (95th percentile, so a brief peak does not shrink the others) is
  // 0.35 of the sphere's radius
  var frameMax = [];
  for (var n = 0; n < N; n++) frameMax.push(0);
  function biggest(keys) {
    for (var i = 0; i < N; i++) {
      var v = keys.length === 3 ? Math.hypot(S[keys[0]][i], S[keys[1]][i], S[keys[2]][i]) : Math.abs(S[keys[0]][i]);
      if (fin(v) && v > frameMax[i]) frameMax[i] = v;
    }
  }
  G.joints.forEach(function (j) { biggest(["Fx:" + j.name, "Fy:" + j.name, "Fz:" + j.name]); });
  (G.loads || []).forEach(function (l) { if (l.kind === "force") biggest(l.v); });
  D.drivers.forEach(function (d) { if (d.unit === "N") biggest([d.key]); });
  var ranked = frameMax.filter(function (v) { return v > 0; }).sort(function (a, b) { return a - b; });
  var fall = ranked.length ? ranked[Math.floor(0.95 * (ranked.length - 1))] : 0;
  var wscale = fall > 0 ? 0.35 * G.radius / fall : 0;
  window.__linkdynForces = {scale: wscale};
  var fleg = null;
  if (wscale > 0) {
    var fmag = Math.pow(10, Math.floor(Math.log10(fall / 2.5)));
    var Fr = [1, 2, 5, 10].map(function (f) { return f * fmag; }).filter(function (v) { return v <= fall / 2.5 * 1.0001; }).pop() || fmag;
    fleg = {Fr: Fr, g: el("g", {id: "force-legend", "data-force": Fr}, gForces)};
    fleg.line = el("line", {stroke: LD.FORCE.joint, "stroke-width": 2.2, "marker-end": "url(#arrow3-r)"}, fleg.g);
    fleg.t = el("text", {"text-anchor": "end", "font-size": 12, fill: LD.FORCE.joint}, fleg.g);
    fleg.t.textContent = "force scale: " + fmt(Fr, 3) + " N";
  }
  var loadArrows = (G.loads || []).map(function (l) {
    return {l: l, a: el(l.kind === "force" ? "line" : "path", {fill: "none", stroke: LD.FORCE.load, "stroke-width": 2.2,
                                                              "marker-end": "url(#arrow3-l)", "class": "farrow"}, gForces),
            t: el("text", {"font-size": 11, fill: LD.FORCE.load}, gFLabels)};
  });
  var drvArrows = D.drivers.map(function (d) {
    var j = G.joints.filter(function (x) { return x.name === d.joint; })[0];
    return {d: d, j: j, a: el(d.unit === "N m" ? "path" : "line", {fill: "none", stroke: LD.FORCE.driver, "stroke-width": 2.4,
                                                                  "marker-end": "url(#arrow3-d)", "class": "farrow"}, gForces),
            t: el("text", {"font-size": 11, fill: LD.FORCE.driver}, gFLabels)};
  });
  // an arrow from p (m) along f (N): hidden when shorter than 2 px on the view
  function arrow(a, p, f) {
    var q0 = proj(p), q1 = proj(add(p, f, wscale)), ok = wscale > 0 && ok3(f) && Math.hypot(q1[0] - q0[0], q1[1] - q0[1]) > 2;
    a.style.display = ok ? "" : "none";
    if (ok) { a.setAttribute("x1", q0[0].toFixed(2)); a.setAttribute("y1", q0[1].toFixed(2));
              a.setAttribute("x2", q1[0].toFixed(2)); a.setAttribute("y2", q1[1].toFixed(2)); }
    return ok ? q1 : null;
  }
  // a couple m (N m) at p: a 270-degree arc in the plane normal to it, turning by the right hand
  function curl(a, p, m, rad) {
    var L = Math.hypot(m[0], m[1], m[2]);
    if (!(L > 0) || !ok3(p)) { a.style.display = "none"; return null; }
    var e = [m[0] / L, m[1] / L, m[2] / L], t = Math.abs(e[2]) < 0.9 ? [0, 0, 1] : [1, 0, 0];
    var b1 = [e[1] * t[2] - e[2] * t[1], e[2] * t[0] - e[0] * t[2], e[0] * t[1] - e[1] * t[0]], nb = Math.hypot(b1[0], b1[1], b1[2]);
    b1 = [b1[0] / nb, b1[1] / nb, b1[2] / nb];
    var b2 = [e[1] * b1[2] - e[2] * b1[1], e[2] * b1[0] - e[0] * b1[2], e[0] * b1[1] - e[1] * b1[0]], d = "";
    for (var i = 0; i <= 18; i++) {
      var th = 1.5 * Math.PI * i / 18, s = proj(add(add(p, b1, rad * Math.cos(th)), b2, rad * Math.sin(th)));
      d += (i ? "L" : "M") + xy(s);
    }
    a.setAttribute("d", d); a.style.display = "";
    return proj(add(p, b1, rad));
  }

  // ------------------------------------------------------------------ the scale bar and axes gizmo
  var bar = el("path", {fill: "none", stroke: "#444", "stroke-width": 2}, gHud),
      barText = el("text", {"font-size": 12, fill: "#444"}, gHud);
  var gizmo = AX.map(function (a) {
    return {a: a, line: el("line", {stroke: a[2], "stroke-width": 2.2, "stroke-linecap": "round"}, gHud),
            t: el("text", {"font-size": 11, fill: a[2], "font-weight": "bold", "text-anchor": "middle"}, gHud)};
  });
  gizmo.forEach(function (o) { o.t.textContent = o.a[0]; });
  function drawHud() {
    var s = cam.fit * cam.zoom, target = VW / 5 / s, m0 = Math.pow(10, Math.floor(Math.log10(target)));
    var L = [1, 2, 5, 10].map(function (f) { return f * m0; }).filter(function (v) { return v <= target; }).pop() || m0;
    var x0 = 70 * textScale, y0 = VH - 12 * textScale, w = L * s;
    bar.setAttribute("d", "M" + x0 + "," + (y0 - 4) + "v8M" + x0 + "," + y0 + "h" + w.toFixed(1) + "M" + (x0 + w).toFixed(1) + "," + (y0 - 4) + "v8");
    barText.setAttribute("x", (x0 + w + 6).toFixed(1)); barText.setAttribute("y", (y0 + 4 * textScale).toFixed(1));
    barText.textContent = L >= 1 ? fmt(L, 3) + " m" : fmt(L * 1000, 3) + " mm";
    gizmo.forEach(function (o) {   // the global axes' directions, bottom left, 22 px long
      var gx = 34 * textScale, gy = VH - 40 * textScale, ex = 22 * textScale * dot(o.a[1], R), ey = -22 * textScale * dot(o.a[1], U);
      o.line.setAttribute("x1", gx); o.line.setAttribute("y1", gy);
      o.line.setAttribute("x2", (gx + ex).toFixed(1)); o.line.setAttribute("y2", (gy + ey).toFixed(1));
      o.t.setAttribute("x", (gx + 1.35 * ex).toFixed(1)); o.t.setAttribute("y", (gy + 1.35 * ey + 4).toFixed(1));
    });
    if (fleg) {
      var lw = fleg.Fr * wscale * s, lx1 = VW - 14, ly = VH - 12 * textScale;
      fleg.line.setAttribute("x1", (lx1 - lw).toFixed(1)); fleg.line.setAttribute("x2", lx1);
      fleg.line.setAttribute("y1", ly); fleg.line.setAttribute("y2", ly);
      fleg.t.setAttribute("x", (lx1 - lw - 6).toFixed(1)); fleg.t.setAttribute("y", (ly + 4 * textScale).toFixed(1));
      fleg.g.setAttribute("data-length", lw.toFixed(4));
    }
  }

  // ------------------------------------------------------------------ drawing a frame
  function label(node, s, dx, dy) {
    node.setAttribute("x", (s[0] + dx * textScale).toFixed(1)); node.setAttribute("y", (s[1] + dy * textScale).toFixed(1));
  }
  function seg(line, a, b) {
    line.setAttribute("x1", a[0].toFixed(1)); line.setAttribute("y1", a[1].toFixed(1));
    line.setAttribute("x2", b[0].toFixed(1)); line.setAttribute("y2", b[1].toFixed(1));
  }
  var frame = 0;
  function draw(k) {
    frame = k;
    axes();
    // the floor, the origin's axes, the ground
    gridPath.setAttribute("d", grid.map(function (l) { return "M" + xy(proj(l[0])) + "L" + xy(proj(l[1])); }).join(""));
    var o0 = proj([0, 0, 0]);
    originAxes.forEach(function (o) {
      var e = proj(add([0, 0, 0], o.a[1], 0.12 * G.radius));
      seg(o.line, o0, e); label(o.t, e, 3, 3);
    });
    if (groundLine) groundLine.setAttribute("d", G.ground.map(function (id, i) { return (i ? "L" : "M") + xy(proj(P(id, 0))); }).join("") + (G.ground.length > 2 ? "Z" : ""));
    G.ground.forEach(function (id, i) { var s = proj(P(id, 0)); bases[i].setAttribute("d", "M" + xy(s) + " l-9,15 h18 z"); });
    traces.forEach(function (o) {
      var p = G.points[o.id], d = "", pen = false;
      for (var i = 0; i < N; i++) {
        var q = [p.x[i], p.y[i], p.z[i]];
        if (ok3(q)) { d += (pen ? "L" : "M") + xy(proj(q)); pen = true; } else pen = false;
      }
      o.path.setAttribute("d", d);
      var q = P(o.id, k), okq = ok3(q);
      o.dot.style.display = okq ? "" : "none";
      if (okq) { var s = proj(q); o.dot.setAttribute("cx", s[0].toFixed(1)); o.dot.setAttribute("cy", s[1].toFixed(1)); }
    });
    // bodies, the farthest first
    bodies.forEach(function (o) {
      var pts = o.b.outline.map(function (id) { return P(id, k); }), ok = pts.every(ok3);
      o.node.style.display = o.lab.style.display = ok ? "" : "none";
      if (!ok) { o.depth = -Infinity; return; }
      var sp = pts.map(proj), cx = 0, cy = 0, dz = 0;
      sp.forEach(function (s) { cx += s[0]; cy += s[1]; dz += s[2]; });
      cx /= sp.length; cy /= sp.length; o.depth = dz / sp.length;
      if (o.b.shape === "dot") { o.node.setAttribute("cx", sp[0][0].toFixed(1)); o.node.setAttribute("cy", sp[0][1].toFixed(1)); }
      else o.node.setAttribute("points", sp.map(xy).join(" "));
      o.ax = cx; o.ay = cy;
    });
    bodies.slice().sort(function (a, b) { return a.depth - b.depth; }).forEach(function (o) { gBodies.appendChild(o.node); });
    springs.forEach(function (o) {
      var a = P(o.s.at, k), b = P(o.s.to, k), ok = ok3(a) && ok3(b);
      o.node.style.display = ok ? "" : "none";
      if (ok) seg(o.node, proj(a), proj(b));
    });
    // joints and their reactions
    var best = -1, bestF = -1;
    joints.forEach(function (o, n) {
      var p = P(o.j.b, k), ok = ok3(p);
      o.g.style.display = o.lab.style.display = ok ? "" : "none";
      if (!ok) { o.arrow.style.display = o.flab.style.display = "none"; o.s = o.tip = null; return; }
      var s = proj(p), pp = o.parts;
      o.s = s;
      o.c.setAttribute("cx", s[0].toFixed(2)); o.c.setAttribute("cy", s[1].toFixed(2));
      var e = o.j.axis ? vec(o.j.axis, k) : null;
      if (e && pp.pin) seg(pp.pin, proj(add(p, e, -Lpin)), proj(add(p, e, Lpin)));
      if (e && pp.sleeve) seg(pp.sleeve, proj(add(p, e, -0.45 * Lpin)), proj(add(p, e, 0.45 * Lpin)));
      if (e && pp.block) { seg(pp.rail, proj(add(p, e, -2.5 * Lpin)), proj(add(p, e, 2.5 * Lpin)));
                           seg(pp.block, proj(add(p, e, -0.6 * Lpin)), proj(add(p, e, 0.6 * Lpin))); }
      if (e && pp.cross1) { var e2 = vec(o.j.axis2, k);
                            seg(pp.cross1, proj(add(p, e, -0.8 * Lpin)), proj(add(p, e, 0.8 * Lpin)));
                            seg(pp.cross2, proj(add(p, e2, -0.8 * Lpin)), proj(add(p, e2, 0.8 * Lpin))); }

      var f = S["F:" + o.j.name][k], F = vec(["Fx:" + o.j.name, "Fy:" + o.j.name, "Fz:" + o.j.name], k);
      if (fin(f) && f > bestF) { bestF = f; best = n; }
      var tip = arrow(o.arrow, p, F);
      o.arrow.setAttribute("data-f", fin(f) ? f : "");
      o.flab.style.display = tip ? "" : "none";
      o.flab.textContent = o.j.name + " " + fmtS("F:" + o.j.name, f) + " N";
      o.tip = tip;
    });
    ring.style.display = best >= 0 ? "" : "none";
    if (best >= 0) { ring.setAttribute("cx", joints[best].s[0].toFixed(1)); ring.setAttribute("cy", joints[best].s[1].toFixed(1)); }
    // loads and the driver efforts
    loadArrows.forEach(function (o) {
      var p = P(o.l.at, k), v = vec(o.l.v, k), tip;
      if (o.l.kind === "force") tip = arrow(o.a, p, v);
      else tip = curl(o.a, p, v, 0.16 * G.radius);
      o.t.style.display = tip ? "" : "none";
      o.t.textContent = o.l.label + " " + fmt(Math.hypot(v[0], v[1], v[2]), 4) + (o.l.kind === "force" ? " N" : " N m");
      o.tip = tip;
    });
    drvArrows.forEach(function (o) {
      var v = S[o.d.key][k], tip = null;
      if (o.j && o.j.axis && fin(v)) {
        var p = P(o.j.b, k), e = vec(o.j.axis, k);
        tip = o.d.unit === "N m" ? (v !== 0 ? curl(o.a, p, [e[0] * v, e[1] * v, e[2] * v], 0.13 * G.radius) : null)
                                 : arrow(o.a, p, [e[0] * v, e[1] * v, e[2] * v]);
      }
      if (!tip) o.a.style.display = "none";
      o.t.style.display = tip ? "" : "none";
      o.t.textContent = "driver " + o.d.joint + " " + fmtS(o.d.key, v) + " " + o.d.unit;
      o.tip = tip;
    });
    drawHud();
    // labels clear of each other and of the joints (LD.placer, common.js): joint names first,
    // then bodies, then the forces' values at their arrows' tips
    var obst = [], rj = 7 * textScale, items = [];
    joints.forEach(function (o) { if (o.g.style.display !== "none") obst.push([o.s[0] - rj, o.s[1] - rj, o.s[0] + rj, o.s[1] + rj]); });
    if (showLabels) {
      joints.forEach(function (o) { if (o.s) items.push({node: o.lab, x: o.s[0], y: o.s[1], fs: 11.5, r: 8}); });
      bodies.forEach(function (o) { items.push({node: o.lab, x: o.ax, y: o.ay, fs: 12, r: 6}); });
    }
    // a force's value never drops out: with no room by its tip, at the view's edge with a
    // dashed leader line to the tip
    joints.concat(loadArrows, drvArrows).forEach(function (o) {
      var node = o.flab || o.t;
      o.leader = o.leader || el("line", {stroke: node.getAttribute("fill"), "stroke-dasharray": "3 2", "class": "leader"}, gFLabels);
      o.leader.style.display = "none";
      if (showForces && o.tip) {
        node.style.display = "";
        items.push({node: node, x: o.tip[0], y: o.tip[1], fs: 11, r: 3, edge: true, leader: o.leader});
      }
    });
    // the bodies as drawn at this frame (a bar's thick line, a plate with its border, a dot)
    // and the blocks and sleeves on their second bodies: a force's label keeps clear of them
    // (LD.placer), as on the planar view; viewBox units, as the strokes are
    var shapes = [];
    bodies.forEach(function (o) {
      if (o.node.style.display === "none") return;
      var sp = o.b.outline.map(function (id) { return proj(P(id, k)); });
      if (o.b.shape === "polygon") shapes.push({pts: sp, r: 2, closed: true});
      else if (o.b.shape === "dot") shapes.push({pts: sp.slice(0, 1), r: 6});
      else shapes.push({pts: sp, r: 4});
    });
    joints.forEach(function (o) {
      if (!o.s) return;
      [[o.parts.block, 7], [o.parts.sleeve, 5.5]].forEach(function (b) {
        var line = b[0];
        if (!line || !line.hasAttribute("x1")) return;
        shapes.push({pts: [[+line.getAttribute("x1"), +line.getAttribute("y1")],
                           [+line.getAttribute("x2"), +line.getAttribute("y2")]], r: b[1]});
      });
    });
    place(items, obst, textScale, shapes);
    return best;
  }

  // ------------------------------------------------------------------ turning and zooming
  function redraw() { draw(frame); }
  function setView(az, elev, zoom) {
    cam.az = az; cam.el = Math.max(-89.9 * DEG, Math.min(89.9 * DEG, elev));
    if (zoom !== undefined) cam.zoom = Math.max(0.2, Math.min(20, zoom));
    redraw();
  }
  var pointers = {}, pinch = null;
  function svgScale() { var w = anim.getBoundingClientRect().width; return w > 0 ? VW / w : 1; }
  anim.addEventListener("pointerdown", function (e) {
    pointers[e.pointerId] = [e.clientX, e.clientY];
    try { anim.setPointerCapture(e.pointerId); } catch (err) { /* synthetic pointer */ }
    anim.style.cursor = "grabbing";
    var ids = Object.keys(pointers);
    if (ids.length === 2) {
      var a = pointers[ids[0]], b = pointers[ids[1]];
      pinch = {d: Math.hypot(a[0] - b[0], a[1] - b[1]) || 1, zoom: cam.zoom};
    }
  });
  anim.addEventListener("pointermove", function (e) {
    var last = pointers[e.pointerId];
    if (!last) return;
    pointers[e.pointerId] = [e.clientX, e.clientY];
    var ids = Object.keys(pointers);
    if (ids.length === 2 && pinch) {   // two fingers: pinch to zoom
      var a = pointers[ids[0]], b = pointers[ids[1]];
      setView(cam.az, cam.el, pinch.zoom * (Math.hypot(a[0] - b[0], a[1] - b[1]) || 1) / pinch.d);
      return;
    }
    // one pointer: turn, half a degree per pixel of the view
    var f = 0.5 * DEG * svgScale();
    setView(cam.az - (e.clientX - last[0]) * f, cam.el + (e.clientY - last[1]) * f);
  });
  function up(e) {
    delete pointers[e.pointerId];
    if (Object.keys(pointers).length < 2) pinch = null;
    anim.style.cursor = "grab";
  }
  anim.addEventListener("pointerup", up);
  anim.addEventListener("pointercancel", up);
  anim.addEventListener("wheel", function (e) {
    e.preventDefault();
    setView(cam.az, cam.el, cam.zoom * Math.exp(-0.0015 * e.deltaY));
  }, {passive: false});
  // the view's buttons: back to the starting view, or along an axis
  var box = LD.h("div", "controls viewbar", null);
  anim.parentNode.insertBefore(box, anim.nextSibling);
  [["reset view", home.az, home.el, "view-reset"], ["top", -90, 89.9, "view-top"],
   ["front", -90, 0, "view-front"], ["side", 0, 0, "view-side"]].forEach(function (v) {
    var b = LD.h("button", "", box, v[0]);
    b.type = "button"; b.id = v[3];
    b.title = v[0] === "reset view" ? "the starting view and zoom" : "look along " + {top: "-z", front: "+y", side: "-x"}[v[0]];
    b.addEventListener("click", function () { setView(v[1] * DEG, v[2] * DEG, 1); });
  });
  LD.h("span", "note", box, "drag to turn, wheel or pinch to zoom");

  // texts keep about their size on the screen whatever the page's width (a phone shows the
  // 640-unit view in ~360 px): font sizes and label offsets grow by textScale
  var textScale = 1;
  function resize() {
    var w = anim.getBoundingClientRect().width;
    textScale = w > 0 ? Math.max(1, Math.min(2.2, VW / w)) : 1;
    Array.prototype.forEach.call(anim.querySelectorAll("text"), function (t) {
      if (!t.hasAttribute("data-fs")) t.setAttribute("data-fs", t.getAttribute("font-size") || 12);
      t.setAttribute("font-size", (parseFloat(t.getAttribute("data-fs")) * textScale).toFixed(1));
    });
  }
  function show(what, on) {
    var disp = on ? "" : "none";
    if (what === "labels") { showLabels = on; gLabels.style.display = disp; }
    else if (what === "traces") gTraces.style.display = disp;
    else if (what === "forces") { showForces = on; gForces.style.display = gFLabels.style.display = disp; }
  }
  axes();
  return {draw: draw, resize: resize, show: show, toggles: ["labels", "traces", "forces"]};
};
