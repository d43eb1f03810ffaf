/* linkdyn sweep: the scatter of any two columns of a sweep's designs coloured by a third, the
   Pareto front of two metrics (computed in Python), the best designs of a metric and filters
   on every column. Every number is in the model file's units (D.cols, D.units). Inlined into
   sweep.html after common.js; reads the JSON in #linkdyn-data; no network, no library. */
(function () {
  "use strict";
  var D = JSON.parse(document.getElementById("linkdyn-data").textContent);
  var el = LD.el, h = LD.h, fin = LD.fin, fmt = LD.fmt, niceStep = LD.niceStep,
      tickText = LD.tickText, range = LD.range;
  var PW = 640, PH = 420, ML = 64, MR = 16, MT = 16, MB = 40;
  var columns = D.params.concat(D.metrics), N = D.design.length;
  var box = document.getElementById("scatter");
  var sx = document.getElementById("sx"), sy = document.getElementById("sy");
  var pa = document.getElementById("pa"), pb = document.getElementById("pb");
  var hide = document.getElementById("hideinvalid");
  var bm = document.getElementById("bm"), bn = document.getElementById("bn");
  var sc = document.getElementById("sc"), ftab = document.getElementById("filters");
  var limits = {};   // column -> [min or null, max or null], from the filter inputs

  // a metric's sense: +1 where smaller is better, -1 where larger is (D.senses)
  function sgn(m) { return D.senses && D.senses[m] === "max" ? -1 : 1; }
  function fill(sel, names, k, senses) {
    names.forEach(function (c) {
      var o = h("option", "", sel, senses ? c + (sgn(c) < 0 ? " (larger)" : " (smaller)") : c);
      o.value = c;
    });
    if (names.length) sel.value = names[Math.min(k, names.length - 1)];
  }
  function label(c) { return D.units[c] ? c + " (" + D.units[c] + ")" : c; }
  // an axis title: the column, its unit and, for a metric, which way is better
  function axisLabel(c) {
    return label(c) + (D.senses[c] ? (sgn(c) < 0 ? ", larger is better" : ", smaller is better") : "");
  }
  // whether design i meets every filter (a limit on a column it has no value of: it does not)
  function passes(i) {
    for (var c in limits) {
      var v = D.cols[c][i], lo = limits[c][0], hi = limits[c][1];
      if ((lo !== null || hi !== null) && !fin(v)) return false;
      if ((lo !== null && v < lo) || (hi !== null && v > hi)) return false;
    }
    return true;
  }
  // the parameters design i sits on a bound of: [[column, -1 low | +1 high], ...]
  function edgesOf(i) {
    var out = [];
    D.params.forEach(function (c) { var e = D.edges[c] && D.edges[c][i]; if (e) out.push([c, e]); });
    return out;
  }
  // viridis, five stops: the colour of a fraction f in [0, 1]
  var RAMP = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
  function ramp(f) {
    f = Math.max(0, Math.min(1, f)) * (RAMP.length - 1);
    var k = Math.min(RAMP.length - 2, Math.floor(f)), u = f - k, a = RAMP[k], b = RAMP[k + 1];
    return "rgb(" + [0, 1, 2].map(function (n) { return Math.round(a[n] + u * (b[n] - a[n])); }).join(",") + ")";
  }
  // the front of the chosen pair of metrics: indices into the rows ([] for one metric twice)
  function front() {
    return D.fronts[pa.value + "|" + pb.value] || D.fronts[pb.value + "|" + pa.value] || [];
  }
  // one row of a design as readout lines
  function rowLines(i) {
    var out = ["design " + D.design[i] + (D.valid[i] ? "" : " (invalid: " + D.reason[i] + ")")];
    columns.forEach(function (c) { out.push(label(c) + " = " + fmt(D.cols[c][i])); });
    edgesOf(i).forEach(function (e) { out.push("at the " + (e[1] < 0 ? "low" : "high") + " bound of " + e[0]); });
    return out;
  }

  function draw() {
    box.innerHTML = "";
    // a log10 axis drops the designs whose value is not positive
    var lx = document.getElementById("logx").checked, ly = document.getElementById("logy").checked;
    var tr = function (a, lg) { return lg ? a.map(function (v) { return fin(v) && v > 0 ? Math.log10(v) : null; }) : a; };
    var X = tr(D.cols[sx.value], lx), Y = tr(D.cols[sy.value], ly), onFront = {};
    // the front of all valid designs, those that meet the filters
    var frAll = front(), fr = frAll.filter(passes);
    fr.forEach(function (i) { onFront[i] = true; });
    var shown = [];
    for (var i = 0; i < N; i++)
      if (fin(X[i]) && fin(Y[i]) && (D.valid[i] || !hide.checked) && passes(i)) shown.push(i);
    // colour by a third column: its range over the shown designs
    var C = sc.value ? D.cols[sc.value] : null, cr = null;
    if (C) cr = range([shown.map(function (i) { return C[i]; })]);
    box.className = "panel" + (C ? " coloured" : "");
    var xr = range([shown.map(function (i) { return X[i]; })]),
        yr = range([shown.map(function (i) { return Y[i]; })]);
    var px = 0.04 * (xr[1] - xr[0]), py = 0.05 * (yr[1] - yr[0]);
    xr = [xr[0] - px, xr[1] + px]; yr = [yr[0] - py, yr[1] + py];
    var svg = el("svg", {viewBox: "0 0 " + PW + " " + PH}, box);
    var x0 = ML, x1 = PW - MR, y0 = PH - MB, y1 = MT;
    var fx = function (v) { return x0 + (v - xr[0]) / (xr[1] - xr[0]) * (x1 - x0); };
    var fy = function (v) { return y0 - (v - yr[0]) / (yr[1] - yr[0]) * (y0 - y1); };
    // axes and ticks
    var st = niceStep(yr[1] - yr[0], 6), v;
    for (v = Math.ceil(yr[0] / st) * st; v <= yr[1]; v += st) {
      el("line", {x1: x0, x2: x1, y1: fy(v), y2: fy(v), "class": "gridl"}, svg);
      el("text", {x: x0 - 4, y: fy(v) + 3.5, "text-anchor": "end", "class": "tick"}, svg).textContent = tickText(v, st);
    }
    var xt = niceStep(xr[1] - xr[0], 7);
    for (v = Math.ceil(xr[0] / xt) * xt; v <= xr[1]; v += xt)
      el("text", {x: fx(v), y: y0 + 15, "text-anchor": "middle", "class": "tick"}, svg).textContent = tickText(v, xt);
    el("line", {x1: x0, x2: x0, y1: y0, y2: y1, "class": "axis"}, svg);
    el("line", {x1: x0, x2: x1, y1: y0, y2: y0, "class": "axis"}, svg);
    el("text", {x: x1, y: PH - 4, "text-anchor": "end", "class": "tick"}, svg).textContent = (lx ? "log10 " : "") + axisLabel(sx.value);
    el("text", {x: 4, y: 10, "class": "tick"}, svg).textContent = (ly ? "log10 " : "") + axisLabel(sy.value);
    // the front joined by a line when the axes are its two metrics
    var same = sx.value === pa.value && sy.value === pb.value, swap = sx.value === pb.value && sy.value === pa.value;
    if ((same || swap) && fr.length) {
      var pts = fr.slice().sort(function (i, j) { return X[i] - X[j] || Y[i] - Y[j]; }), d = "";
      pts.forEach(function (i, k) { d += (k ? "L" : "M") + fx(X[i]).toFixed(1) + "," + fy(Y[i]).toFixed(1); });
      el("path", {d: d, "class": "frontline"}, svg);
    }
    // one point per shown design; the front's in red, invalid ones grey
    shown.forEach(function (i) {
      var cls = "pt" + (D.valid[i] ? "" : " invalid") + (onFront[i] ? " front" : "") +
                (edgesOf(i).length ? " edge" : "");
      var c = el("circle", {cx: fx(X[i]).toFixed(1), cy: fy(Y[i]).toFixed(1), r: onFront[i] ? 4.5 : 3,
                            "class": cls, "data-row": i}, svg);
      if (C && fin(C[i])) c.style.fill = ramp((C[i] - cr[0]) / (cr[1] - cr[0]));
    });
    var bar = document.getElementById("colorbar");
    bar.style.display = C ? "flex" : "none";
    if (C) {
      document.getElementById("cblo").textContent = fmt(cr[0]);
      document.getElementById("cbhi").textContent = fmt(cr[1]) + (D.units[sc.value] ? " " + D.units[sc.value] : "");
      document.getElementById("cbname").textContent = "colour: " + axisLabel(sc.value);
    }
    var filtered = Object.keys(limits).length > 0;
    document.getElementById("frontnote").textContent = D.metrics.length < 2 ? "the front needs two metrics (sweep with two --metric or more)" :
      pa.value === pb.value ? "choose two different metrics" :
      (filtered ? fr.length + " of the front's " + frAll.length + " designs (over all valid designs) meet the filters (red)" :
                  fr.length + " designs on the front (red)") +
      (same || swap ? "" : "; plot these two metrics to see its line");
    // hover readout: the nearest shown point
    var tip = h("div", "tooltip", box), hot = null;
    svg.addEventListener("pointermove", function (e) {
      var r = svg.getBoundingClientRect(), mx = (e.clientX - r.left) / r.width * PW, my = (e.clientY - r.top) / r.height * PH;
      var best = -1, bd = 400;
      shown.forEach(function (i) { var dx = fx(X[i]) - mx, dy = fy(Y[i]) - my, dd = dx * dx + dy * dy; if (dd < bd) { bd = dd; best = i; } });
      if (hot) hot.classList.remove("hot");
      if (best < 0) { tip.style.display = "none"; hot = null; return; }
      hot = svg.querySelector("circle[data-row='" + best + "']"); hot.classList.add("hot");
      tip.innerHTML = "";
      rowLines(best).forEach(function (t, k) { h("div", k ? "tr" : "tt", tip, t); });
      tip.setAttribute("data-row", best);
      LD.placeTip(tip, box, e);
    });
    svg.addEventListener("pointerleave", function () { tip.style.display = "none"; if (hot) hot.classList.remove("hot"); });
  }

  // the best valid designs of a metric in its sense (largest first where larger is better)
  function best() {
    var m = bm.value, col = D.cols[m], n = +bn.value, t = document.getElementById("best"), s = sgn(m);
    var rows = [];
    var ok = 0;
    for (var i = 0; i < N; i++) if (D.valid[i] && fin(col[i]) && passes(i)) rows.push(i);
    for (i = 0; i < N; i++) if (passes(i)) ok++;
    rows.sort(function (i, j) { return s * (col[i] - col[j]) || i - j; });
    rows = rows.slice(0, n);
    document.getElementById("filternote").textContent = Object.keys(limits).length ?
      ok + " of " + N + " designs meet the filters" : "";
    // the ranking metric first, then the other metrics, then the parameters: what decides
    // is in view without scrolling sideways
    var order = [m].concat(D.metrics.filter(function (c) { return c !== m; }), D.params);
    t.innerHTML = "";
    var hr = h("tr", "", h("thead", "", t));
    h("th", "", hr, "design");
    order.forEach(function (c) { h("th", "", hr, label(c)).setAttribute("data-col", c); });
    var tb = h("tbody", "", t);
    rows.forEach(function (i) {
      var tr = h("tr", "", tb), edges = {};
      tr.setAttribute("data-row", i);
      edgesOf(i).forEach(function (e) { edges[e[0]] = e[1]; });
      h("td", "num", tr, String(D.design[i]));
      order.forEach(function (c) {
        var td = h("td", "num", tr, fmt(D.cols[c][i]));
        td.setAttribute("data-col", c);
        if (c === m) td.style.fontWeight = "bold";
        if (edges[c]) { td.className = "num edge"; td.setAttribute("data-edge", edges[c] < 0 ? "low bound" : "high bound"); }
      });
    });
    // the best design on a bound of its range: the best may lie beyond it
    var note = "";
    if (rows.length && edgesOf(rows[0]).length)
      note = "The best design by " + m + " (design " + D.design[rows[0]] + ") sits at " +
        edgesOf(rows[0]).map(function (e) {
          return "the " + (e[1] < 0 ? "low" : "high") + " bound of " + e[0] + " (" +
            fmt(D.ranges[e[0]][e[1] < 0 ? 0 : 1]) + (D.units[e[0]] ? " " + D.units[e[0]] : "") + ")";
        }).join(" and ") + ": a better design may lie beyond it; widen that range.";
    document.getElementById("edgenote").textContent = note;
    // each best design with its own report page beside this one: click its row to animate it
    var shown = null;
    if (rows.some(function (i) { return D.previews[String(D.design[i])]; })) h("th", "", hr, "report");
    rows.forEach(function (i) {
      var file = D.previews[String(D.design[i])], tr = tb.querySelector("tr[data-row='" + i + "']");
      if (!file) return;
      tr.setAttribute("data-preview", file);
      var a = h("a", "", h("td", "", tr), "open");
      a.href = file; a.target = "_blank";
      tr.addEventListener("click", function (e) { if (e.target.tagName !== "A") preview(tr); });
      if (!shown) shown = tr;
    });
    if (shown) preview(shown);
    document.getElementById("previewnote").textContent = shown ? "Below: the highlighted " +
      "design's own report (as linkdyn analyze --report writes it, with its animation); click " +
      "a row to show another." : "";
    document.getElementById("cmpcmd").textContent =
      "linkdyn compare --sweep " + D.outdir + " --by " + m + " --best " + n + " -o " + D.outdir + "/compare";
  }

  function preview(tr) {
    var f = document.getElementById("preview");
    Array.prototype.forEach.call(document.querySelectorAll("#best tr.shown"), function (r) { r.classList.remove("shown"); });
    tr.classList.add("shown");
    if (f.getAttribute("src") !== tr.getAttribute("data-preview")) f.setAttribute("src", tr.getAttribute("data-preview"));
    f.style.display = "block";
  }

  // one row per column: its min and max limits, the range of its values beside them
  function filters() {
    var hr = h("tr", "", h("thead", "", ftab));
    ["column", "min", "max", "values"].forEach(function (t) { h("th", "", hr, t); });
    var tb = h("tbody", "", ftab);
    D.metrics.concat(D.params).forEach(function (c) {
      var tr = h("tr", "", tb), r = range([D.cols[c]]);
      tr.setAttribute("data-col", c);
      h("th", "", tr, label(c));
      ["min", "max"].forEach(function (k, n) {
        var inp = h("input", "", h("td", "", tr));
        inp.type = "number"; inp.step = "any"; inp.setAttribute("data-limit", k);
        inp.setAttribute("aria-label", k + " " + c);
        inp.addEventListener("input", function () {
          var v = inp.value === "" ? null : +inp.value, cur = limits[c] || [null, null];
          cur[n] = fin(v) ? v : null;
          if (cur[0] === null && cur[1] === null) delete limits[c]; else limits[c] = cur;
          draw(); best();
        });
      });
      h("td", "span", tr, fmt(r[0]) + " .. " + fmt(r[1]));
    });
  }

  // default axes: the two metrics that trade off most (D.pair), else the first parameter and
  // the metric
  var two = D.metrics.length > 1;
  fill(sx, columns, two ? columns.indexOf(D.pair[0]) : 0);
  fill(sy, columns, two ? columns.indexOf(D.pair[1]) : D.params.length);
  fill(pa, D.metrics, two ? D.metrics.indexOf(D.pair[0]) : 0, true);
  fill(pb, D.metrics, two ? D.metrics.indexOf(D.pair[1]) : 1, true);
  fill(bm, D.metrics, 0, true);
  h("option", "", sc, "none").value = "";
  fill(sc, columns, 0);
  sc.value = two ? (D.metrics.filter(function (c) { return D.pair.indexOf(c) < 0; })[0] || "") : "";
  filters();
  [sx, sy, sc, pa, pb, hide, document.getElementById("logx"), document.getElementById("logy")].forEach(function (s) { s.addEventListener("change", draw); });
  [bm, bn].forEach(function (s) { s.addEventListener("change", best); });
  draw(); best();
  window.__linkdynSweep = true;
})();
