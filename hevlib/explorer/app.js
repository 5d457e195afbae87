// hev-sizing front explorer (reports/explorer.html): parallel coordinates with brushing, a scatter of any two
// axes and a table of the brushed designs, drawn by the bundled Plotly. Data: window.HEV_DATA (hevlib/explorer).
(function () {
  "use strict";
  var D = window.HEV_DATA;
  var names = D.axes.map(function (a) { return a.name; });
  var label = function (a) { return a.unit && a.unit !== "-" ? a.name + " [" + a.unit + "]" : a.name; };
  var rows = D.rows;                       // every design on a source's front (sizing cycle, simulated)
  var pcRows = rows.concat(D.baselines.filter(function (b) { return b.values.every(function (v) { return v !== null; }); }));
  var STATUS = { front: 0, kept: 1, picked: 2, equivalent: 3, recommended: 4, baseline: 5 };
  var STATUS_NAMES = ["front", "kept", "picked", "near-equivalent", "recommended"];
  var COLOURS = ["#c8c8c8", "#6a9fd4", "#f28e2b", "#9467bd", "#d62728", "#2ca02c"];
  var pc = document.getElementById("parcoords");
  var sc = document.getElementById("scatter");
  var brushed = rows.slice();

  function status(r) {
    if (r.baseline) return STATUS.baseline;
    if (r.recommended) return STATUS.recommended;
    if (r.equivalent) return STATUS.equivalent;
    if (r.picked) return STATUS.picked;
    return r.kept ? STATUS.kept : STATUS.front;
  }

  function fmt(v) { return v === null || v === undefined ? "n/a" : Number(v).toPrecision(6).replace(/\.?0+(e|$)/, "$1"); }

  // ------------------------------------------------------------------ parallel coordinates
  var scale = COLOURS.map(function (c, i) { return [[i / COLOURS.length, c], [(i + 1) / COLOURS.length, c]]; })
    .reduce(function (a, b) { return a.concat(b); }, []);
  Plotly.newPlot(pc, [{
    type: "parcoords",
    line: { color: pcRows.map(status), colorscale: scale, cmin: -0.5, cmax: COLOURS.length - 0.5 },
    dimensions: D.axes.map(function (a, j) {
      return { label: label(a), values: pcRows.map(function (r) { return r.values[j]; }) };
    }),
  }], { margin: { l: 60, r: 60, t: 60, b: 30 }, font: { size: 10 } }, { responsive: true, displaylogo: false });

  function inRange(v, range) {
    if (!range) return true;
    var list = Array.isArray(range[0]) ? range : [range];
    return list.some(function (r) { return v !== null && v >= r[0] && v <= r[1]; });
  }

  function brush() {
    var dims = pc.data[0].dimensions;
    brushed = rows.filter(function (r) {
      return dims.every(function (d, j) { return inRange(r.values[j], d.constraintrange); });
    });
    renderTable();
    renderScatter();
  }
  pc.on("plotly_restyle", brush);

  // ------------------------------------------------------------------ scatter of any two axes
  var xs = document.getElementById("x-axis"), ys = document.getElementById("y-axis");
  D.axes.forEach(function (a, j) {
    [xs, ys].forEach(function (s) { var o = document.createElement("option"); o.value = j; o.textContent = label(a); s.appendChild(o); });
  });
  xs.value = names.indexOf(D.default_x); ys.value = names.indexOf(D.default_y);
  xs.onchange = ys.onchange = function () { renderScatter(); };

  function points(list, name, marker) {
    var jx = +xs.value, jy = +ys.value;
    return {
      type: "scatter", mode: "markers", name: name, marker: marker,
      x: list.map(function (r) { return r.values[jx]; }), y: list.map(function (r) { return r.values[jy]; }),
      text: list.map(function (r) { return r.id; }), hovertemplate: "%{text}<br>%{x}<br>%{y}<extra>" + name + "</extra>",
    };
  }

  function renderScatter() {
    var traces = D.sources.map(function (s) {
      return points(rows.filter(function (r) { return r.sources.indexOf(s) >= 0; }), s + " front", { size: 5, opacity: 0.35 });
    });
    if (brushed.length < rows.length) traces.push(points(brushed, "brushed", { size: 7, color: "#111", symbol: "circle-open" }));
    traces.push(points(rows.filter(function (r) { return r.picked; }), "picks", { size: 10, color: COLOURS[2], symbol: "circle-open", line: { width: 2 } }));
    traces.push(points(rows.filter(function (r) { return r.equivalent; }), "near-equivalents", { size: 13, color: COLOURS[STATUS.equivalent], symbol: "star-open", line: { width: 2 } }));
    traces.push(points(rows.filter(function (r) { return r.recommended; }), "recommended", { size: 16, color: COLOURS[STATUS.recommended], symbol: "star" }));
    D.baselines.forEach(function (b, i) {
      traces.push(points([b], b.id, { size: 13, color: i ? "#555" : COLOURS[STATUS.baseline], symbol: i ? "square" : "diamond" }));
    });
    Plotly.react(sc, traces, {
      margin: { l: 70, r: 20, t: 20, b: 60 }, xaxis: { title: { text: label(D.axes[+xs.value]) } },
      yaxis: { title: { text: label(D.axes[+ys.value]) } }, legend: { orientation: "h", y: -0.2 },
    }, { responsive: true, displaylogo: false });
  }

  // ------------------------------------------------------------------ table of the brushed designs
  var table = document.getElementById("designs");
  function renderTable() {
    var head = "<tr><th>design</th><th>sources</th><th>status</th>" + D.axes.map(function (a) { return "<th>" + label(a) + "</th>"; }).join("") + "</tr>";
    var body = brushed.map(function (r) {
      var st = STATUS_NAMES[status(r)];
      return "<tr data-id=\"" + r.id + "\"><td>" + r.id + "</td><td>" + r.sources.join("+") + "</td><td>" + st + "</td>" +
        r.values.map(function (v) { return "<td>" + fmt(v) + "</td>"; }).join("") + "</tr>";
    }).join("");
    table.innerHTML = "<thead>" + head + "</thead><tbody>" + body + "</tbody>";
    document.getElementById("count").textContent = brushed.length + " of " + rows.length + " designs";
  }

  // ------------------------------------------------------------------ copy as a designs CSV (hev simulate --designs)
  document.getElementById("copy").onclick = function () {
    var vars = D.design_vars, idx = vars.map(function (v) { return names.indexOf(v); });
    var lines = ["design_id," + vars.join(",")].concat(brushed.map(function (r) {
      return r.id + "," + idx.map(function (j) { return String(r.values[j]); }).join(",");
    }));
    var text = lines.join("\n") + "\n";
    var area = document.getElementById("csv");
    area.value = text; area.style.display = "block";
    if (navigator.clipboard && navigator.clipboard.writeText) navigator.clipboard.writeText(text).catch(function () {});
  };

  // ------------------------------------------------------------------ the controller's gap (hev bound; validation.json)
  function renderGap() {
    var G = D.gap;
    if (!G) return;
    var names = Object.keys(G.controllers);
    var pct = function (v) { return v === null || v === undefined ? "n/a" : (v > 0 ? "+" : "") + v.toFixed(1) + " %"; };
    var head = "<tr><th>cycle</th><th>vehicle</th>" + names.map(function (n) { return "<th>" + n + " [L/100 km]</th>"; }).join("") +
      names.slice(0, -1).map(function (n) { return "<th>" + n + " over bound</th>"; }).join("") + "<th>note</th></tr>";
    var body = "";
    Object.keys(G.by_cycle).forEach(function (c) {
      var V = G.by_cycle[c].vehicles;
      Object.keys(V).forEach(function (v) {
        var e = V[v], rec = v === G.recommended;
        body += "<tr data-gap=\"" + c + ":" + v + "\"" + (rec ? " style=\"font-weight:bold\"" : "") + "><td>" + c + "</td><td>" +
          v + (rec ? " (recommended)" : "") + "</td>" + names.map(function (n) { return "<td>" + fmt(e.fc_l_100km[n]) + "</td>"; }).join("") +
          names.slice(0, -1).map(function (n) { return "<td>" + pct(e.over_bound_pct[n]) + "</td>"; }).join("") + "<td>" + e.note + "</td></tr>";
      });
    });
    document.getElementById("gap").innerHTML = "<thead>" + head + "</thead><tbody>" + body + "</tbody>";
    var savings = Object.keys(G.by_cycle).filter(function (c) { return G.by_cycle[c].saving_pct; }).map(function (c) {
      var s = G.by_cycle[c].saving_pct;
      return c + ": " + Object.keys(s).map(function (n) { return n + " " + (s[n] === null ? "n/a" : s[n].toFixed(1) + " %"); }).join(", ");
    });
    document.getElementById("gap-intro").textContent = "Fuel under " + names.map(function (n) { return n + " (" + G.controllers[n] + ")"; }).join("; ") +
      "; " + G.yardstick + "." + (savings.length ? " Saving of the recommended design against the conventional car under each controller: " + savings.join("; ") + "." : "");
    document.getElementById("gap-section").style.display = "block";
  }

  renderTable();
  renderScatter();
  renderGap();
  window.hevExplorer = { brushed: function () { return brushed.map(function (r) { return r.id; }); }, ready: true };
})();
