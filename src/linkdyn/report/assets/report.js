/* linkdyn report: animation + plots synchronised on one time cursor. Inlined into report.html;
   reads the JSON in #linkdyn-data; no network, no library. */
(function () {
  "use strict";
  var D = JSON.parse(document.getElementById("linkdyn-data").textContent);
  D.series = LD.unpack(D.series);
  D.t = LD.unpack({t: D.t}).t;
  LD.unpackGeom(D.geom);
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

  // ------------------------------------------------------------------ the view (view2d.js, view3d.js)
  // the mechanism drawn at a frame: in the plane or in space, by the data's dimension
  var view = (G.dim === 3 ? LD.view3d : LD.view2d)(D, anim, fmtS);

  // the free-body view of a link (freebody.js; in space as the 3-D view's camera sees it),
  // drawn while on the screen
  var fbSec = document.getElementById("freebody"), fbView = null, fbSeen = true;
  if (fbSec && G.freebody && G.freebody.length) {
    fbView = LD.freebody(D);
    if (typeof IntersectionObserver === "function") {
      new IntersectionObserver(function (es) {
        fbSeen = es[es.length - 1].isIntersecting;
        if (fbSeen) fbView.draw(frame);
      }, {rootMargin: "100px"}).observe(fbSec);
    }
  } else if (fbSec) fbSec.style.display = "none";

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
    h("th", "", tr, "joint"); h("th", "", tr, "|F| now"); h("th", "", tr, "vs. its run peak");
  })();
  // each joint's own peak |F| over the run (the page's frames hold every joint's peak sample)
  var Fpeak = {};
  G.joints.forEach(function (j) {
    var a = S["F:" + j.name] || [], p = 0;
    for (var i = 0; i < a.length; i++) if (fin(a[i]) && a[i] > p) p = a[i];
    Fpeak[j.name] = p;
  });
  var jfBody = h("tbody", "", elJF);
  var jfRows = G.joints.map(function (j) {
    var tr = h("tr", "", jfBody);
    h("th", "", tr, j.name);
    var td = h("td", "num", tr), bar = h("td", "bar", tr), fb = h("span", "fbar", bar);
    bar.title = "run peak " + fmtS("F:" + j.name, Fpeak[j.name]) + " N";
    return {tr: tr, td: td, bar: fb, name: j.name};
  });
  function drawInfo(k, best) {
    elTime.textContent = "t = " + T[k].toFixed(4) + " s";
    elFrame.textContent = "frame " + (k + 1) + " / " + N + (D.valid[k] ? "" : "  (singular: NaN)");
    drv.forEach(function (o) {
      var q = S[o.d.q] ? S[o.d.q][k] : null;
      o.eff.textContent = " driver " + o.d.word + " " + fmtS(o.d.key, S[o.d.key][k]) + " " + o.d.unit;
      o.q.textContent = fin(q) ? "at q = " + fmtS(o.d.q, q) + " " + o.d.qunit : "";
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
      var p = Fpeak[o.name];
      o.bar.style.width = (fin(f) && p > 0 ? Math.min(100, 100 * f / p) : 0).toFixed(1) + "%";
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
      // the plot (grid, ticks, curves: drawn once) and above it, in a layer of its own, what
      // moves with the frame (the cursor, its dots, the hover line), so that a frame repaints
      // only that layer and never the panel's curves
      var pbox = h("div", "pbox", panel);
      var svg = el("svg", {viewBox: "0 0 " + PW + " " + PH, "class": "plot"}, pbox);
      var ov = el("svg", {viewBox: "0 0 " + PW + " " + PH, "class": "overlay", "aria-hidden": "true"}, pbox);
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
      var cursor = el("line", {"class": "cursor", x1: x0, x2: x0, y1: y0, y2: y1}, ov);
      if (polar) cursor.setAttribute("class", "cursor polar");
      var dots = spec.series.map(function (s) { return el("circle", {"class": "dot", r: 3, fill: s.color, stroke: "#fff", "stroke-width": 1}, ov); });
      var leg = h("div", "legend", panel);
      var vals = spec.series.map(function (s) {
        var it = h("span", "", leg), sw = h("i", "", it); sw.style.background = s.color;
        h("span", "", it, s.label);
        var b = h("b", "", it, "");
        b.setAttribute("data-key", s.key);
        return b;
      });
      var xval = null;
      if (spec.x) { var xit = h("span", "", leg); h("span", "", xit, spec.x.short || xm.label); xval = h("b", "", xit, ""); }
      var hover = el("line", {"class": "hoverline", x1: x0, x2: x0, y1: y0, y2: y1}, ov);
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
      // a press (a tap on a phone, which has no hover) picks the frame and shows its readout;
      // a finger lifted keeps it, a mouse that leaves hides it
      hit.addEventListener("pointerdown", function (e) { down = true; try { hit.setPointerCapture(e.pointerId); } catch (err) {} pick(e); readout(e); });
      hit.addEventListener("pointermove", function (e) { if (down) pick(e); readout(e); });
      hit.addEventListener("pointerup", function () { down = false; });
      hit.addEventListener("pointerleave", function (e) { if (e.pointerType === "touch") return; tip.style.display = "none"; hover.style.display = "none"; });
      exportButtons(panel, spec, svg);
      var entry = {spec: spec, svg: svg, sx: sx, sy: sy, xs: xs, cursor: cursor, dots: dots, vals: vals, xval: xval, polar: polar, y0: y0, y1: y1, seen: true, k: -1};
      plots.push(entry);
      if (seen) { entry.seen = false; seen.observe(panel); panel.__plot = entry; }
    });
  }
  // the panels on the screen: while playing, only these follow each frame (a panel scrolled
  // into view catches up with the frame shown; a pause brings every panel to it)
  var seen = typeof IntersectionObserver === "function" ? new IntersectionObserver(function (entries) {
    entries.forEach(function (e) {
      var p = e.target.__plot;
      if (!p) return;
      p.seen = e.isIntersecting;
      if (p.seen && p.k !== frame) drawPlot(p, frame);
    });
  }, {rootMargin: "100px"}) : null;
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
  // a panel as a figure of its own: no cursor, dots or hover line (the page's state), and
  // its legend (each series' colour and label) in rows below the plot
  function panelFigure(svg, spec) {
    var c = svg.cloneNode(true);
    Array.prototype.slice.call(c.querySelectorAll(".cursor,.dot,.hoverline")).forEach(function (e) { e.remove(); });
    var x = ML, y = PH + 8, rows = [];
    spec.series.forEach(function (s) {
      var w = 22 + 6.2 * s.label.length;
      if (x + w > PW - 4 && x > ML) { x = ML; y += 15; }
      rows.push([s, x, y]); x += w + 12;
    });
    var H = spec.series.length ? y + 12 : PH;
    rows.forEach(function (r) {
      el("line", {x1: r[1], x2: r[1] + 14, y1: r[2], y2: r[2], stroke: r[0].color, "stroke-width": 3}, c);
      el("text", {x: r[1] + 18, y: r[2] + 3.5, "class": "tick legendtext"}, c).textContent = r[0].label;
    });
    c.setAttribute("xmlns", NS); c.setAttribute("width", PW); c.setAttribute("height", H);
    c.setAttribute("viewBox", "0 0 " + PW + " " + H);
    var st = document.createElementNS(NS, "style");
    st.textContent = "text{font-family:DejaVu Sans,Helvetica,Arial,sans-serif}.ptitle{font-size:12.5px;font-weight:bold}" +
      ".tick{font-size:10.5px;fill:#444}.axis{stroke:#888}.gridl{stroke:#eceff2}.zero{stroke:#b9c0c7}" +
      ".series{fill:none;stroke-width:1.6}";
    c.insertBefore(st, c.firstChild);
    var bg = document.createElementNS(NS, "rect");
    bg.setAttribute("width", PW); bg.setAttribute("height", H); bg.setAttribute("fill", "#fff");
    c.insertBefore(bg, st.nextSibling);
    return {text: new XMLSerializer().serializeToString(c), height: H};
  }
  function exportButtons(panel, spec, svg) {
    var bar = h("div", "pexport", panel), name = slug(spec.title);
    var b1 = h("button", "", bar, "CSV"); b1.type = "button"; b1.title = "the panel's series as CSV";
    b1.addEventListener("click", function () { download(name + ".csv", new Blob([panelCSV(spec)], {type: "text/csv"})); });
    var b2 = h("button", "", bar, "SVG"); b2.type = "button";
    b2.addEventListener("click", function () { download(name + ".svg", new Blob([panelFigure(svg, spec).text], {type: "image/svg+xml"})); });
    var b3 = h("button", "", bar, "PNG"); b3.type = "button";
    b3.addEventListener("click", function () {
      var fig = panelFigure(svg, spec), img = new Image(), url = URL.createObjectURL(new Blob([fig.text], {type: "image/svg+xml"}));
      img.onload = function () {
        var cv = document.createElement("canvas"); cv.width = PW * 2; cv.height = fig.height * 2;
        var cx = cv.getContext("2d"); cx.scale(2, 2); cx.drawImage(img, 0, 0);
        URL.revokeObjectURL(url);
        cv.toBlob(function (blob) { download(name + ".png", blob); }, "image/png");
      };
      img.src = url;
    });
  }
  window.__linkdynExport = {csv: function (n) { return panelCSV(D.plots[n]); },
                            svg: function (n) { return panelFigure(plots[n].svg, plots[n].spec).text; }};

  // each panel's cursor, dots and readouts at frame k: every panel (all), or those on the screen
  function drawPlots(k, all) {
    plots.forEach(function (p) { if (all || p.seen) drawPlot(p, k); });
  }
  function drawPlot(p, k) {
    p.k = k;
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
    var best = view.draw(k);
    drawPlots(k, !playing);
    if (fbView && (fbSeen || !playing)) fbView.draw(k);
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
  function pause() {
    var was = playing;
    playing = false; btnPlay.textContent = "▶ Play";
    if (was) { drawPlots(frame, true); keepHash(); }
  }
  btnPlay.addEventListener("click", function () { if (playing) pause(); else play(); });
  document.getElementById("step").addEventListener("click", function () { pause(); setFrame(frame + 1); });
  document.getElementById("stepback").addEventListener("click", function () { pause(); setFrame(frame - 1); });
  scrub.addEventListener("input", function () { pause(); setFrame(parseInt(scrub.value, 10), true); });
  selSpeed.addEventListener("change", function () { speed = parseFloat(selSpeed.value) || 1; });
  speed = parseFloat(selSpeed.value) || 1;
  D.xaxes.forEach(function (a, n) {
    var o = document.createElement("option"); o.value = String(n); o.textContent = a.label; selX.appendChild(o);
  });
  selX.addEventListener("change", function () {
    if (seen) seen.disconnect();
    xmode = D.xaxes[parseInt(selX.value, 10)]; buildPlots(); drawPlots(frame, true);
  });
  // the force key, shown with the forces: what each arrow's colour is (the scale is the bar
  // drawn in the view)
  var fkey = document.getElementById("forcekey"), hasTorque = false, hasForce = false;
  (G.loads || []).forEach(function (l) { if (l.kind === "force") hasForce = true; else if (l.kind !== "spring" && l.kind !== "damper") hasTorque = true; });
  [["joint", "joint force: by the joint's first body on its second, at the joint", true],
   ["load", "applied " + (hasForce && hasTorque ? "force or torque" : hasTorque ? "torque" : "force"), hasForce || hasTorque],
   ["driver", "driver effort", D.drivers.length > 0],
   ["shaking", "shaking force on the frame", !!G.shaking]].forEach(function (e) {
    if (!e[2]) return;
    var it = h("span", "fk", fkey), sw = h("i", "", it);
    sw.style.background = LD.FORCE[e[0]];
    it.setAttribute("data-kind", e[0]);
    h("span", "", it, e[1]);
  });
  // the view's toggles (a view without instant centres hides that one)
  [["show-labels", "labels"], ["show-traces", "traces"], ["show-forces", "forces"], ["show-ics", "ics"]].forEach(function (b) {
    var box = document.getElementById(b[0]);
    if (view.toggles.indexOf(b[1]) < 0) { box.parentNode.style.display = "none"; return; }
    box.addEventListener("change", function (e) {
      view.show(b[1], e.target.checked);
      if (b[1] === "forces") fkey.hidden = !e.target.checked;
      setFrame(frame);
    });
  });
  window.addEventListener("resize", function () { view.resize(); setFrame(frame); });
  view.resize();
  document.addEventListener("keydown", function (e) {
    var tag = (e.target && e.target.tagName) || "";
    // a field keeps its keys, a button its Space; the arrows step the frame from a button too
    // (after a click on a key result, which focuses it)
    if (tag === "INPUT" || tag === "SELECT" || tag === "TEXTAREA") return;
    if (tag === "BUTTON" && (e.key === " " || e.key === "Enter")) return;
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
