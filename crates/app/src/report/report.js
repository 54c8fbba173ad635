// pneumo report: builds one uPlot panel per quantity from the JSON data
// block. Writes nothing from the data as markup: labels go through
// textContent (here and in uPlot). Its state is left on <body> for the
// headless-browser test: data-plots (panels drawn), data-points (non-null
// values handed to the plots), data-markers (measured values drawn as
// markers, with --experiments), data-errors (script errors and Content-
// Security-Policy violations, joined).
(function () {
  "use strict";
  var errors = [];
  var drawn = 0;
  var points = 0;
  var markers = 0;
  function mark() {
    document.body.setAttribute("data-plots", String(drawn));
    document.body.setAttribute("data-points", String(points));
    document.body.setAttribute("data-markers", String(markers));
    document.body.setAttribute("data-errors", errors.join(" | "));
  }
  window.addEventListener("error", function (e) {
    errors.push("error: " + e.message);
    mark();
  });
  document.addEventListener("securitypolicyviolation", function (e) {
    errors.push("CSP violation: " + e.violatedDirective + " " + e.blockedURI);
    mark();
  });
  var palette = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];
  var plots = [];
  function width() {
    var host = document.getElementById("plots");
    return Math.max(320, Math.min(host.clientWidth || 900, 1100));
  }
  function noPath() {
    return null;
  }
  try {
    var data = JSON.parse(document.getElementById("pneumo-data").textContent);
    data.panels.forEach(function (p) {
      var box = document.createElement("div");
      box.className = "panel";
      var heading = document.createElement("h3");
      heading.textContent = p.title;
      box.appendChild(heading);
      if (p.note) {
        var note = document.createElement("p");
        note.className = "hint";
        note.textContent = p.note;
        box.appendChild(note);
      }
      document.getElementById(p.host || "plots").appendChild(box);
      var series = [{ label: data.x_label }];
      var columns = [p.time || data.time];
      p.series.forEach(function (s, i) {
        var color = s.color || palette[i % palette.length];
        var count = 0;
        s.values.forEach(function (v) {
          if (v !== null) count += 1;
        });
        if (s.markers) {
          // measurements: markers only, no line between samples
          series.push({ label: s.label, stroke: color, width: 1, paths: noPath, points: { show: true, size: 4, stroke: color, fill: color } });
          markers += count;
        } else {
          series.push({ label: s.label, stroke: color, width: 1.5, points: { show: false } });
        }
        columns.push(s.values);
        points += count;
      });
      var y = { auto: true };
      if (p.range) y = { auto: false, range: p.range };
      var opts = {
        width: width(),
        height: 240,
        series: series,
        scales: { x: { time: false }, y: y },
        axes: [{ label: data.x_label }, { label: p.y_label, size: 64 }],
        cursor: { sync: { key: p.sync || "pneumo" }, drag: { x: true, y: false } },
        legend: { live: true }
      };
      plots.push(new uPlot(opts, columns, box));
      drawn += 1;
    });
    window.addEventListener("resize", function () {
      plots.forEach(function (u) {
        u.setSize({ width: width(), height: 240 });
      });
    });
  } catch (e) {
    errors.push("error: " + e);
  }
  mark();
})();
