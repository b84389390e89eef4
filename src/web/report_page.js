// moa report page: draws the charts from the JSON in #moa-data with Chart.js.
//
// Zoom: drag a box on a chart, double-click to reset. The time charts zoom
// together. The x-y charts keep one metre the same length on both axes.
// Colours: each sensor has one colour (sensorColor), used for it in every
// chart, its legend and the tables, and for nothing else; everything that
// is not a sensor is black or grey. The truth is a thin dashed black line
// drawn over the estimate, a wide grey band with a marker every few
// points, so the two stay apart where they overlap.
// When done, each canvas carries data-painted ("1" when anything is drawn
// on it) and data-points (data elements drawn), and the body carries
// data-moa-status="ready": the browser test reads them.
(function () {
  'use strict';

  var data = JSON.parse(document.getElementById('moa-data').textContent);
  // Okabe & Ito's colour-blind-safe set first, then Tol's muted set.
  var palette = ['#0072b2', '#e69f00', '#009e73', '#cc79a7', '#56b4e9', '#d55e00', '#f0e442',
                 '#882255', '#44aa99', '#999933', '#aa4499', '#117733', '#332288', '#ddcc77',
                 '#88ccee', '#661100'];
  var ink = '#111', grey = '#888';
  var charts = [];
  var timeCharts = [];

  Chart.defaults.animation = false;
  Chart.defaults.maintainAspectRatio = false;
  Chart.defaults.font.family = 'system-ui, -apple-system, "Segoe UI", Roboto, sans-serif';
  Chart.defaults.font.size = 12;
  Chart.defaults.plugins.legend.labels.boxWidth = 14;

  function num(x, digits) {
    return x === null || x === undefined ? '-' : Number(x).toPrecision(digits || 4);
  }
  function sensorColor(i) { return palette[i % palette.length]; }
  function points(xs, ys, ts) {
    var out = new Array(xs.length);
    for (var k = 0; k < xs.length; ++k) out[k] = {x: xs[k], y: ys[k], t: ts ? ts[k] : undefined};
    return out;
  }
  function gap() { return {x: null, y: null}; }
  function reportError(where, e) {
    var text = where + ': ' + (e && e.message ? e.message : String(e));
    window.moaErrors.push(text);
    var box = document.getElementById('moa-errors');
    box.textContent = window.moaErrors.join('\n');
    box.hidden = false;
  }

  // Names of the points that carry one (`name`), drawn beside them.
  var labelPlugin = {
    id: 'moaLabels',
    afterDatasetsDraw: function (chart) {
      var ctx = chart.ctx;
      ctx.save();
      ctx.font = '12px ' + Chart.defaults.font.family;
      ctx.fillStyle = '#222';
      chart.data.datasets.forEach(function (ds, i) {
        if (!ds.moaLabels || !chart.isDatasetVisible(i)) return;
        chart.getDatasetMeta(i).data.forEach(function (el, k) {
          var name = ds.data[k] && ds.data[k].name;
          if (name) ctx.fillText(name, el.x + 7, el.y - 7);
        });
      });
      ctx.restore();
    }
  };

  // x-y charts: the limits widened on one axis so that a metre is as long
  // on x as on y.
  function equalise(chart, lim) {
    chart.$limits = lim;
    for (var pass = 0; pass < 2; ++pass) {  // the axes' labels may move the area once
      var a = chart.chartArea;
      var w = a.right - a.left, h = a.bottom - a.top;
      var cx = (lim.x[0] + lim.x[1]) / 2, cy = (lim.y[0] + lim.y[1]) / 2;
      var s = Math.max((lim.x[1] - lim.x[0]) / w, (lim.y[1] - lim.y[0]) / h);
      if (!(s > 0) || !isFinite(s)) s = 1e-3;
      var sx = chart.options.scales.x, sy = chart.options.scales.y;
      sx.min = cx - s * w / 2;
      sx.max = cx + s * w / 2;
      sy.min = cy - s * h / 2;
      sy.max = cy + s * h / 2;
      chart.update('none');
    }
  }

  function bounds(datasets, margin) {
    var x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    datasets.forEach(function (ds) {
      ds.data.forEach(function (p) {
        if (p.x === null || p.y === null) return;
        x0 = Math.min(x0, p.x); x1 = Math.max(x1, p.x);
        y0 = Math.min(y0, p.y); y1 = Math.max(y1, p.y);
      });
    });
    if (!isFinite(x0)) return {x: [-1, 1], y: [-1, 1]};
    var m = Math.max(x1 - x0, y1 - y0) * margin + 1e-3;
    return {x: [x0 - m, x1 + m], y: [y0 - m, y1 + m]};
  }

  function setTimeRange(range) {
    timeCharts.forEach(function (chart) {
      chart.options.scales.x.min = range[0];
      chart.options.scales.x.max = range[1];
      chart.update('none');
    });
  }

  // Box zoom: kind 'xy' zooms both axes (equal scale), 'x' the time axis of
  // every time chart.
  function attachZoom(chart, kind) {
    var canvas = chart.canvas;
    var box = document.createElement('div');
    box.className = 'zoombox';
    canvas.parentNode.appendChild(box);
    var start = null;
    function at(e) {
      var r = canvas.getBoundingClientRect();
      return {x: e.clientX - r.left, y: e.clientY - r.top};
    }
    function inside(p) {
      var a = chart.chartArea;
      return p.x >= a.left && p.x <= a.right && p.y >= a.top && p.y <= a.bottom;
    }
    function corners(p) {
      var a = chart.chartArea;
      var x0 = Math.max(a.left, Math.min(start.x, p.x)), x1 = Math.min(a.right, Math.max(start.x, p.x));
      var y0 = kind === 'x' ? a.top : Math.max(a.top, Math.min(start.y, p.y));
      var y1 = kind === 'x' ? a.bottom : Math.min(a.bottom, Math.max(start.y, p.y));
      return {x0: x0, x1: x1, y0: y0, y1: y1};
    }
    canvas.addEventListener('mousedown', function (e) {
      var p = at(e);
      if (e.button === 0 && inside(p)) start = p;
    });
    window.addEventListener('mousemove', function (e) {
      if (!start) return;
      var c = corners(at(e));
      box.style.left = c.x0 + 'px';
      box.style.top = c.y0 + 'px';
      box.style.width = (c.x1 - c.x0) + 'px';
      box.style.height = (c.y1 - c.y0) + 'px';
      box.style.display = 'block';
    });
    window.addEventListener('mouseup', function (e) {
      if (!start) return;
      var c = corners(at(e));
      start = null;
      box.style.display = 'none';
      if (c.x1 - c.x0 < 5 || (kind === 'xy' && c.y1 - c.y0 < 5)) return;
      var sx = chart.scales.x, sy = chart.scales.y;
      var xr = [sx.getValueForPixel(c.x0), sx.getValueForPixel(c.x1)];
      if (kind === 'x') {
        setTimeRange(xr);
      } else {
        equalise(chart, {x: xr, y: [sy.getValueForPixel(c.y1), sy.getValueForPixel(c.y0)]});
      }
    });
    canvas.addEventListener('dblclick', function () {
      if (kind === 'x') {
        setTimeRange([data.t0, data.t1]);
      } else {
        equalise(chart, chart.$home);
      }
    });
  }

  function xyChart(id, datasets, title) {
    var chart = new Chart(document.getElementById(id), {
      type: 'scatter',
      data: {datasets: datasets},
      plugins: [labelPlugin],
      options: {
        interaction: {mode: 'nearest', intersect: false, axis: 'xy'},
        scales: {
          x: {type: 'linear', title: {display: true, text: title[0]}, ticks: {includeBounds: false}},
          y: {type: 'linear', title: {display: true, text: title[1]}, ticks: {includeBounds: false}}
        },
        plugins: {
          // A dataset whose points have the sensors' colours shows moaLegendColor
          // in the legend, not its first point's colour.
          legend: {labels: {sort: function (a, b) { return a.datasetIndex - b.datasetIndex; },
                            generateLabels: function (c) {
            var items = Chart.defaults.plugins.legend.labels.generateLabels(c);
            items.forEach(function (item) {
              var color = c.data.datasets[item.datasetIndex].moaLegendColor;
              if (color) item.fillStyle = item.strokeStyle = color;
            });
            return items;
          }}},
          tooltip: {
            filter: function (item) { return !item.dataset.moaQuiet && item.raw && item.raw.x !== null; },
            callbacks: {
              label: function (ctx) {
                var r = ctx.raw;
                var s = (r.name ? r.name + ' ' : '') + ctx.dataset.label + ': (' + num(r.x) + ', ' +
                        num(r.y) + ') m';
                if (r.t !== undefined) s += ', t ' + num(r.t, 6) + ' s';
                if (r.note) s += ', ' + r.note;
                return s;
              }
            }
          }
        },
        onResize: function (c) {
          if (c.$limits) window.setTimeout(function () { equalise(c, c.$limits); }, 0);
        }
      }
    });
    chart.$home = bounds(datasets.filter(function (ds) { return !ds.moaQuiet || ds.moaBounds; }), 0.05);
    equalise(chart, chart.$home);
    attachZoom(chart, 'xy');
    charts.push(chart);
    return chart;
  }

  function timeChart(id, datasets, yAxes, extra) {
    var scales = {x: {type: 'linear', min: data.t0, max: data.t1,
                      title: {display: true, text: 'time (s)'}, ticks: {includeBounds: false}}};
    Object.keys(yAxes).forEach(function (k) { scales[k] = yAxes[k]; });
    var options = {
      interaction: {mode: 'nearest', intersect: false, axis: 'x'},
      scales: scales,
      plugins: {tooltip: {filter: function (item) { return item.raw && item.raw.y !== null; }}}
    };
    Object.keys(extra || {}).forEach(function (k) { options[k] = extra[k]; });
    var chart = new Chart(document.getElementById(id),
                          {type: 'line', data: {datasets: datasets}, options: options});
    attachZoom(chart, 'x');
    timeCharts.push(chart);
    charts.push(chart);
    return chart;
  }

  // Sensors on the robot at pose (x, y, theta): world-frame points.
  function robotShape(mounts, pose, radius) {
    var c = Math.cos(pose.theta), s = Math.sin(pose.theta);
    function world(px, py) { return {x: pose.x + c * px - s * py, y: pose.y + s * px + c * py}; }
    var outline = [];
    for (var k = 0; k <= 36; ++k) {
      var a = 2 * Math.PI * k / 36;
      outline.push(world(radius * Math.cos(a), radius * Math.sin(a)));
    }
    outline.push(gap(), world(0, 0), world(radius, 0), gap());
    var sensors = mounts.map(function (m, i) {
      var p = world(m.x, m.y);
      p.name = m.name;
      p.t = pose.t;
      p.color = sensorColor(i);
      return p;
    });
    return {outline: outline, sensors: sensors};
  }

  function robotRadius(mounts) {
    var r = 0;
    mounts.forEach(function (m) { r = Math.max(r, Math.hypot(m.x, m.y)); });
    return r > 0 ? 1.25 * r : 0.05;
  }

  function drawTrajectory() {
    var b = data.bins;
    var every = Math.max(1, Math.round(b.t.length / 40));
    var datasets = [{
      label: 'estimate', data: points(b.x, b.y, b.t), showLine: true, order: 2,
      pointRadius: function (ctx) { return ctx.dataIndex % every === 0 ? 2.5 : 0; },
      pointBackgroundColor: '#555', pointBorderColor: '#555',
      borderColor: 'rgba(0, 0, 0, 0.22)', backgroundColor: 'rgba(0, 0, 0, 0.22)', borderWidth: 6
    }];
    if (data.truth) {
      datasets.push({label: 'truth', data: points(data.truth.x, data.truth.y, data.truth.t),
                     showLine: true, pointRadius: 0, borderColor: ink, backgroundColor: ink,
                     borderWidth: 1.5, borderDash: [6, 4], order: 0});
    }
    if (data.camera) {
      datasets.push({label: 'camera fixes', data: points(data.camera.x, data.camera.y),
                     pointRadius: 4, pointStyle: 'crossRot', borderColor: '#555',
                     backgroundColor: '#555', order: 1});
    }
    var n = b.t.length, radius = robotRadius(data.sensors);
    var outline = [], sensors = data.sensors.map(function () { return []; });
    var shown = Math.min(n, 8);
    for (var k = 0; k < shown; ++k) {
      var i = shown === 1 ? 0 : Math.round(k * (n - 1) / (shown - 1));
      var shape = robotShape(data.sensors, {x: b.x[i], y: b.y[i], theta: b.theta[i], t: b.t[i]}, radius);
      outline = outline.concat(shape.outline);
      shape.sensors.forEach(function (p, s) { sensors[s].push(p); });
    }
    datasets.push({label: 'robot', data: outline, showLine: true, pointRadius: 0, spanGaps: false,
                   borderColor: grey, backgroundColor: grey, borderWidth: 1, moaQuiet: true,
                   moaBounds: true, order: 3});
    data.sensors.forEach(function (m, s) {
      datasets.push({label: m.name, data: sensors[s], pointRadius: 3.5, order: 1,
                     borderColor: sensorColor(s), backgroundColor: sensorColor(s)});
    });
    datasets.push({label: 'start', data: [points(b.x, b.y, b.t)[0]], pointRadius: 6,
                   pointStyle: 'triangle', borderColor: ink, backgroundColor: ink, order: 0});
    datasets.push({label: 'end', data: [points(b.x, b.y, b.t)[n - 1]], pointRadius: 6,
                   pointStyle: 'rect', borderColor: ink, backgroundColor: ink, order: 0});
    xyChart('chart-trajectory', datasets, ['x (m)', 'y (m)']);
  }

  function drawErrors() {
    if (!data.errors) return;
    var t = data.bins.t;
    function scaled(xs, k) { return xs.map(function (x) { return x === null ? null : x * k; }); }
    timeChart('chart-errors', [
      {label: 'translation error (mm)', data: points(t, scaled(data.errors.translation, 1e3)),
       yAxisID: 'y', pointRadius: 0, borderWidth: 1.8, borderColor: ink, backgroundColor: ink,
       spanGaps: false},
      {label: 'heading error (deg)', data: points(t, scaled(data.errors.heading, 180 / Math.PI)),
       yAxisID: 'y1', pointRadius: 0, borderWidth: 1.5, borderDash: [5, 3], borderColor: grey,
       backgroundColor: grey, spanGaps: false}
    ], {
      y: {type: 'linear', position: 'left', beginAtZero: true, title: {display: true, text: 'translation error (mm)'}},
      y1: {type: 'linear', position: 'right', beginAtZero: true, grid: {drawOnChartArea: false},
           title: {display: true, text: 'heading error (deg)'}}
    });
  }

  // States are shades of grey (colours belong to the sensors): light for
  // the normal case, dark for what the estimate left out or fell back to.
  var stateColors = {
    used: '#d4d4d4', mice: '#d4d4d4', wheels: '#8a8a8a', hold: '#111111', absent: '#f2f2f2',
    inconsistent: '#111111', unreliable: '#5a5a5a', lift: '#a8a8a8', fallback: '#707070'
  };
  var otherStates = ['#3a3a3a', '#9a9a9a', '#4a4a4a', '#bababa'];
  function stateColor(name, k) {
    var base = name.split('/')[0];
    var color = stateColors[base] || otherStates[k % otherStates.length];
    if (name.indexOf('/') >= 0) color += 'aa';  // a flagged variant: lighter
    return color;
  }

  function drawTimeline() {
    var tl = data.timeline;
    if (!tl) return;
    var byState = {};
    tl.segments.forEach(function (s) {
      (byState[s[1]] = byState[s[1]] || []).push({y: tl.rows[s[0]], x: [s[2], s[3]], share: s[4]});
    });
    var datasets = Object.keys(byState).map(Number).sort(function (a, b) { return a - b; }).map(function (k) {
      var c = stateColor(tl.states[k], k);
      return {label: tl.states[k], data: byState[k], backgroundColor: c, borderColor: '#999',
              borderWidth: tl.states[k] === 'absent' ? 1 : 0, grouped: false, barPercentage: 0.75, categoryPercentage: 1.0,
              borderSkipped: false};
    });
    var chart = new Chart(document.getElementById('chart-timeline'), {
      type: 'bar',
      data: {labels: tl.rows, datasets: datasets},
      options: {
        indexAxis: 'y',
        interaction: {mode: 'nearest', intersect: true},
        scales: {
          x: {type: 'linear', min: data.t0, max: data.t1, title: {display: true, text: 'time (s)'},
              ticks: {includeBounds: false}},
          y: {type: 'category', labels: tl.rows, offset: true, grid: {offset: true},
              ticks: {font: {weight: 'bold'}, color: function (ctx) {
                return ctx.index < data.sensors.length ? sensorColor(ctx.index) : ink;
              }}}
        },
        plugins: {
          tooltip: {
            callbacks: {
              label: function (ctx) {
                var r = ctx.raw;
                return r.y + ' ' + ctx.dataset.label + ': ' + num(r.x[0], 6) + ' s to ' +
                       num(r.x[1], 6) + ' s (' + Math.round(100 * r.share) + '% of its epochs)';
              }
            }
          }
        }
      }
    });
    attachZoom(chart, 'x');
    timeCharts.push(chart);
    charts.push(chart);
  }

  function drawSpeed() {
    var t = data.bins.t;
    var datasets = data.sensors.map(function (m, i) {
      return {label: m.name, data: points(t, data.speed[i]), pointRadius: 0, borderWidth: 1.3,
              borderColor: sensorColor(i), backgroundColor: sensorColor(i)};
    });
    var groups = {};
    data.sensors.forEach(function (m, i) {
      if (m.max_speed === null) return;
      (groups[m.max_speed] = groups[m.max_speed] || []).push(i);
    });
    var keys = Object.keys(groups);
    keys.forEach(function (key) {
      var members = groups[key];
      var all = keys.length === 1 && members.length === data.sensors.length;
      var color = all ? ink : sensorColor(members[0]);
      var v = Number(key);
      datasets.push({
        label: 'rated max_speed ' + num(v) + ' m/s' + (all ? '' : ' (' + members.map(function (i) {
          return data.sensors[i].name; }).join(', ') + ')'),
        data: [{x: data.t0, y: v}, {x: data.t1, y: v}], pointRadius: 0, borderWidth: 1.5,
        borderDash: [8, 5], borderColor: color, backgroundColor: color
      });
    });
    timeChart('chart-speed', datasets,
              {y: {type: 'linear', beginAtZero: true, title: {display: true, text: 'point speed (m/s)'}}});
  }

  // Self-calibration (moa odometry --self-calibration): each sensor's
  // estimated scale relative to its configured resolution, x solid, y dashed.
  function drawSelfCalibration() {
    if (!data.self_calibration) return;
    var datasets = [];
    data.self_calibration.forEach(function (c, i) {
      if (c.t.length === 0) return;
      var name = data.sensors[i].name;
      datasets.push({label: name + ' scale x', data: points(c.t, c.scale_x), pointRadius: 0,
                     borderWidth: 1.3, borderColor: sensorColor(i), backgroundColor: sensorColor(i)});
      datasets.push({label: name + ' scale y', data: points(c.t, c.scale_y), pointRadius: 0,
                     borderWidth: 1.3, borderDash: [6, 4], borderColor: sensorColor(i),
                     backgroundColor: sensorColor(i)});
    });
    timeChart('chart-self-calibration', datasets,
              {y: {type: 'linear', title: {display: true, text: 'scale (1: as configured)'}}});
  }

  // `drawn` holds the positions and yaws to draw (calibrated ones magnified);
  // the tooltips give the mounts' own values. Without `dash` (the nominal
  // mounts) each sensor is a dataset of its own, so the legend names it in
  // its colour; the x axes are drawn in the sensors' colours.
  function mountShapes(mounts, drawn, label, length, hollow, dash) {
    var axes = [];
    var pts = mounts.map(function (m, i) {
      var d = drawn[i];
      axes.push({x: d.x, y: d.y}, {x: d.x + length * Math.cos(d.yaw), y: d.y + length * Math.sin(d.yaw)}, gap());
      return {x: d.x, y: d.y, name: m.name, color: sensorColor(i),
              note: 'mount (' + num(m.x, 5) + ', ' + num(m.y, 5) + ') m, yaw ' + num(m.yaw, 5) + ' rad' +
                    (m.mirrored ? ', mirrored' : '') +
                    (m.max_speed !== null ? ', max_speed ' + num(m.max_speed) + ' m/s' : '')};
    });
    var colors = pts.map(function (p) { return p.color; });
    var fill = function (c) { return hollow ? 'rgba(0,0,0,0)' : c; };
    var marks = dash ? [{label: label, data: pts, pointRadius: 4, pointBorderWidth: 2, moaLegendColor: ink,
                         pointBorderColor: colors, pointBackgroundColor: colors,
                         borderColor: ink, backgroundColor: ink}]
                     : pts.map(function (p, i) {
                         return {label: (hollow ? label + ' ' : '') + p.name, data: [p],
                                 pointRadius: hollow ? 7 : 4, pointBorderWidth: 2, moaLabels: true,
                                 borderColor: p.color, backgroundColor: fill(p.color)};
                       });
    return marks.concat([
      {label: label.split(' (')[0] + ' x axes', data: axes, showLine: true, pointRadius: 0, spanGaps: false,
       borderColor: ink, backgroundColor: ink, borderWidth: 1.5, borderDash: dash || [],
       segment: {borderColor: function (ctx) { return sensorColor(Math.floor(ctx.p0DataIndex / 3)); }},
       moaQuiet: true, moaBounds: true}
    ]);
  }

  // The largest of 1, 2, 5 times a power of ten not above x (at least 1).
  function niceGain(x) {
    if (!(x > 1) || !isFinite(x)) return 1;
    var p = Math.pow(10, Math.floor(Math.log10(x)));
    return x >= 5 * p ? 5 * p : x >= 2 * p ? 2 * p : p;
  }
  function wrap(a) { return Math.atan2(Math.sin(a), Math.cos(a)); }

  function drawLayout() {
    var radius = robotRadius(data.sensors);
    var outline = robotShape([], {x: 0, y: 0, theta: 0}, radius).outline;
    var length = 0.35 * radius;
    var datasets = [{label: 'robot outline and x axis', data: outline, showLine: true, pointRadius: 0,
                     spanGaps: false, borderColor: grey, backgroundColor: grey, borderWidth: 1,
                     moaQuiet: true, moaBounds: true}];
    datasets = datasets.concat(mountShapes(data.sensors, data.sensors,
                                           data.calibrated ? 'nominal' : 'sensors', length,
                                           !!data.calibrated, null));
    var cal = data.calibrated;
    if (cal) {
      // Calibration moves mounts by millimetres: the changes are drawn
      // magnified (largest shift 15% of the robot's radius, largest yaw change 10 deg).
      var maxShift = 0, maxYaw = 0;
      data.sensors.forEach(function (m, i) {
        maxShift = Math.max(maxShift, Math.hypot(cal[i].x - m.x, cal[i].y - m.y));
        maxYaw = Math.max(maxYaw, Math.abs(wrap(cal[i].yaw - m.yaw)));
      });
      var shiftGain = niceGain(0.15 * radius / maxShift), yawGain = niceGain(0.1745 / maxYaw);
      var drawn = data.sensors.map(function (m, i) {
        return {x: m.x + shiftGain * (cal[i].x - m.x), y: m.y + shiftGain * (cal[i].y - m.y),
                yaw: m.yaw + yawGain * wrap(cal[i].yaw - m.yaw)};
      });
      var gains = [];
      if (shiftGain > 1) gains.push('shifts x' + shiftGain);
      if (yawGain > 1) gains.push('yaw changes x' + yawGain);
      var label = 'calibrated' + (gains.length ? ' (' + gains.join(', ') + ')' : '');
      datasets = datasets.concat(mountShapes(cal, drawn, label, length, false, [5, 3]));
      var shifts = [];
      data.sensors.forEach(function (m, i) { shifts.push({x: m.x, y: m.y}, drawn[i], gap()); });
      datasets.push({label: 'shift', data: shifts, showLine: true, pointRadius: 0, spanGaps: false,
                     borderColor: ink, backgroundColor: ink, borderWidth: 2, moaQuiet: true});
    }
    xyChart('chart-layout', datasets, ['x (m), robot frame', 'y (m), robot frame']);
  }

  // A swatch of the sensor's colour before its name in the tables.
  function colourTables() {
    var index = {};
    data.sensors.forEach(function (m, i) { index[m.name] = i; });
    document.querySelectorAll('table.grid td:first-child').forEach(function (td) {
      var i = index[td.textContent];
      if (i === undefined) return;
      var swatch = document.createElement('span');
      swatch.className = 'swatch';
      swatch.style.background = sensorColor(i);
      td.insertBefore(swatch, td.firstChild);
    });
  }

  function painted(canvas) {
    var d = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    for (var k = 3; k < d.length; k += 4) {
      if (d[k] !== 0) return true;
    }
    return false;
  }

  [['trajectory', drawTrajectory], ['errors', drawErrors], ['timeline', drawTimeline],
   ['speed', drawSpeed], ['self-calibration', drawSelfCalibration], ['layout', drawLayout],
   ['tables', colourTables]].forEach(function (step) {
    try {
      step[1]();
    } catch (e) {
      reportError(step[0], e);
    }
  });

  window.setTimeout(function () {
    charts.forEach(function (chart) {
      var elements = 0;
      chart.data.datasets.forEach(function (ds, i) {
        if (chart.isDatasetVisible(i)) elements += chart.getDatasetMeta(i).data.length;
      });
      chart.canvas.setAttribute('data-points', String(elements));
      chart.canvas.setAttribute('data-painted', painted(chart.canvas) ? '1' : '0');
    });
    document.body.setAttribute('data-moa-status', 'ready');
  }, 0);
})();
