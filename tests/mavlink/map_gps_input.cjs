// `aerovo run --map` with GPS denied, its fixes fused (--map-fix-apply), sending ODOMETRY and
// GPS_INPUT: the messages decoded by node-mavlink (an independent MAVLink implementation),
// never by aerovo's code, and GPS_INPUT put through ArduPilot's arithmetic (gps_input.cjs
// `ardupilot`: AP_GPS_MAV::handle_msg, EKF3's readGpsData and calcGpsGoodToAlign).
//   node map_gps_input.cjs AEROVO VIDEO SRT FOCAL_PX MAP TRUTH_CSV MAX_SIGMA_M SHIFT_M RUN_DIR SRT_TRUE
// VIDEO, TRUTH_CSV: a simulated flight (`aerovo simulate`); MAP: a map of it (`aerovo map build`
// from the flight with its true telemetry); SRT: its telemetry with every fix SHIFT_M metres
// north of the truth, so that the track, geo-referenced by it before GPS is denied at 1 s, is
// SHIFT_M off until the first fused fix takes it back: a jump of the live pose
// (docs/autopilot.md "A pose that jumps"). Fails on:
// - an ODOMETRY per frame whose x/y is not frames.csv's x_m/y_m under one orthogonal map (the
//   first frame's forward-right axes against east-north; 1 mm), whose pose covariance is not
//   finite, positive on its diagonal (0 at the first frame, the origin) and a covariance in x/y
//   (|xy| <= sqrt(xx yy));
// - reset_counter: an increment anywhere but at a frame a fix was fused at (frames.csv
//   status +map_fix) or re-acquired, none at the first fused fix (the SHIFT_M jump), an
//   increment at a fix whose jump (the position's change less the frames' mean step) is not
//   above 5 x max(0.1 m, the previous frame's standard deviation) (mavlink::PoseJumpResetThresholdM),
//   or none at one whose jump is above it with a 20 % margin;
// - a GPS_INPUT: what gps_input.cjs checks through ArduPilot's arithmetic, a position more than
//   1.2 cm from frames.csv's lat/lon (degE7 quantises to 1.1 cm), a fix type that disagrees
//   with horiz_accuracy against MAX_SIGMA_M, a horiz_accuracy that is not the ODOMETRY's larger
//   position standard deviation of the same frame with the drift term over the distance since
//   the first frame or the last fused fix (docs/autopilot.md; 1 cm), no "no fix" before the
//   first fused fix (the drift term past MAX_SIGMA_M), one after it;
// - the positions against the truth: before the first fused fix SHIFT_M off (within 1 m), from
//   it on within 1.5 m; the heights reaching EKF3 (the SRT's abs_alt) within 0.5 m of the
//   truth's altitude.
// Then the same flight over SRT_TRUE (its telemetry unshifted) with GPS denied from the start:
// the map seeds the geo-reference (runSeeded below).
// Exit 0 = pass, 1 = fail (the reasons printed).
'use strict';
const fs = require('fs');
const path = require('path');
const { common } = require('node-mavlink');
const { check, readCsv, listen, runAerovo, finish } = require('./harness.cjs');
const { ardupilot, metresApart, checkKnownHeights, checkNoHeightSent, F } = require('./gps_input.cjs');

const [aerovo, video, srt, focal, map, truthCsv, maxSigma, shiftM, runDir, srtTrue] = process.argv.slice(2);
const MAX_SIGMA = Number(maxSigma), SHIFT = Number(shiftM);
// The drift term of horiz_accuracy, a fraction of the distance flown since the first frame or
// the last fused fix (--mavlink-gps-input-drift): 10 %, so that MAX_SIGMA_M is passed between
// fixes only before the first fix.
const DRIFT = 0.1;
const finite = v => typeof v === 'number' && Number.isFinite(v);

// ODOMETRY pose_covariance: the upper triangle of the 6 x 6 row-major (x, y, z, roll, pitch,
// yaw): xx = [0], xy = [1], yy = [6]; diagonal [0, 6, 11, 15, 18, 20].
// The first frame is the origin: its covariance is 0.
function checkCovariance(c, who, first) {
  check(c.length === 21 && c.every(finite), `${who}: pose_covariance not finite: ${c}`);
  check([0, 6, 11, 15, 18, 20].every(k => (first ? c[k] === 0 : c[k] > 0)), `${who}: pose_covariance diagonal ${[0, 6, 11, 15, 18, 20].map(k => c[k])}`);
  check(Math.abs(c[1]) <= Math.sqrt(c[0] * c[6]) * (1 + 1e-5), `${who}: |xy| ${c[1]} above sqrt(xx yy) ${Math.sqrt(c[0] * c[6])}`);
  return Math.max(c[0], c[6]);
}

// The run over telemetry SHIFT_M off, GPS denied after 1 s (the header's checks).
async function runShifted() {
  const gps = [], odo = [];
  const { sock, splitter, port } = await listen(packet => {
    if (packet.header.msgid === common.GpsInput.MSG_ID) gps.push(packet.protocol.data(packet.payload, common.GpsInput));
    if (packet.header.msgid === common.Odometry.MSG_ID) odo.push(packet.protocol.data(packet.payload, common.Odometry));
  });
  const args = ['run', video, '--telemetry', srt, '--focal-px', focal, '--out', runDir, '-q', '--no-report',
                '--mavlink', `udp:127.0.0.1:${port}`, '--mavlink-time', 'unix', '--mavlink-gps-input',
                '--mavlink-gps-input-max-sigma-m', maxSigma, '--gps-denied-after-s', '1',
                '--mavlink-gps-input-drift', String(DRIFT),
                '--map', map, '--map-fix-apply', '--map-fix-every-n-frames', '4', '--map-fix-search-radius-m', '30'];
  const cpu0 = process.cpuUsage(), wall0 = Date.now();
  const code = await runAerovo(aerovo, args);
  const wallS = (Date.now() - wall0) / 1000;
  sock.close();
  check(code === 0, `aerovo exited with ${code}`);
  check(splitter.invalidPackages === 0, `${splitter.invalidPackages} packets with a bad CRC`);
  if (code !== 0) return;
  const rows = readCsv(path.join(runDir, 'frames.csv'));
  const truth = readCsv(truthCsv);
  const fixes = readCsv(path.join(runDir, 'map_fixes.csv'));
  const summary = JSON.parse(fs.readFileSync(path.join(runDir, 'summary.json'), 'utf8'));
  check(odo.length === rows.length, `${odo.length} ODOMETRY for ${rows.length} frames`);
  const fused = rows.map(r => r.status.includes('+map_fix'));
  const firstFused = fused.indexOf(true);
  check(firstFused > 0, 'no fix fused into the track');
  check(fixes.filter(f => f.applied === '1').length === fused.filter(Boolean).length,
        'map_fixes.csv applied rows and frames.csv +map_fix frames differ');
  // The frames' mean step (m per frame) between the ODOMETRY positions away from the fixes.
  const steps = [];
  for (let i = 1; i < odo.length; ++i) if (!fused[i] && !fused[i - 1]) steps.push(Math.hypot(odo[i].x - odo[i - 1].x, odo[i].y - odo[i - 1].y));
  const meanStep = steps.reduce((a, b) => a + b, 0) / Math.max(1, steps.length);
  // ODOMETRY's x/y (MAV_FRAME_LOCAL_FRD: forward, right of the first frame) against frames.csv's
  // x_m/y_m (east, north): one orthogonal map (a rotation and the handedness' reflection),
  // fitted by least squares over all frames, must hold every frame within 1 mm.
  let sxx = 0, sxy = 0, syy = 0, bx = [0, 0], by = [0, 0];
  for (let i = 0; i < Math.min(odo.length, rows.length); ++i) {
    const e = Number(rows[i].x_m), n = Number(rows[i].y_m);
    sxx += e * e; sxy += e * n; syy += n * n;
    bx = [bx[0] + e * odo[i].x, bx[1] + n * odo[i].x];
    by = [by[0] + e * odo[i].y, by[1] + n * odo[i].y];
  }
  const det = sxx * syy - sxy * sxy;
  const solve = b => [(syy * b[0] - sxy * b[1]) / det, (sxx * b[1] - sxy * b[0]) / det];
  const A = [solve(bx), solve(by)];  // odo = A [e, n]
  const AtA = [A[0][0] ** 2 + A[1][0] ** 2, A[0][0] * A[0][1] + A[1][0] * A[1][1], A[0][1] ** 2 + A[1][1] ** 2];
  check(Math.abs(AtA[0] - 1) < 1e-4 && Math.abs(AtA[1]) < 1e-4 && Math.abs(AtA[2] - 1) < 1e-4,
        `ODOMETRY x/y are not an orthogonal map of frames.csv's x_m/y_m: ${JSON.stringify(A)}`);
  let resetsAtFixes = 0, fusedWithoutReset = 0;
  const varianceOf = [];
  for (let i = 0; i < Math.min(odo.length, rows.length); ++i) {
    const d = odo[i], r = rows[i], who = `ODOMETRY frame ${i} (${r.status})`;
    const e = Number(r.x_m), n = Number(r.y_m);
    const px = A[0][0] * e + A[0][1] * n, py = A[1][0] * e + A[1][1] * n;
    check(Math.abs(d.x - px) <= 1e-3 && Math.abs(d.y - py) <= 1e-3, `${who}: x/y ${d.x}/${d.y} vs frames.csv's x_m/y_m ${e}/${n} mapped: ${px}/${py}`);
    varianceOf[i] = checkCovariance(Array.from(d.poseCovariance), who, i === 0);
    if (i === 0) continue;
    const inc = d.resetCounter - odo[i - 1].resetCounter;
    check(inc === 0 || inc === 1, `${who}: reset_counter ${odo[i - 1].resetCounter} -> ${d.resetCounter}`);
    check(inc === 0 || fused[i] || r.status === 'reacquired', `${who}: reset_counter incremented without a fused fix`);
    if (!fused[i]) continue;
    const jump = Math.hypot(d.x - odo[i - 1].x, d.y - odo[i - 1].y) - meanStep;
    const threshold = 5 * Math.max(0.1, Math.sqrt(varianceOf[i - 1]));
    if (inc === 1) {
      ++resetsAtFixes;
      check(jump > threshold * 0.8, `${who}: a reset at a jump of ${jump.toFixed(2)} m, threshold ${threshold.toFixed(2)} m`);
    } else {
      ++fusedWithoutReset;
      check(jump < threshold * 1.2, `${who}: no reset at a jump of ${jump.toFixed(2)} m, threshold ${threshold.toFixed(2)} m`);
    }
    if (i === firstFused) check(inc === 1 && jump > 0.5 * SHIFT, `${who}: the first fused fix jumps ${jump.toFixed(2)} m with reset_counter +${inc}`);
  }
  check(resetsAtFixes >= 1 && fusedWithoutReset >= 1, `fused fixes with a reset ${resetsAtFixes}, without ${fusedWithoutReset}: both expected`);

  // GPS_INPUT: one per frame from the first geo-referenced one.
  const skipped = rows.length - gps.length;
  check(skipped >= 0 && skipped <= 3, `${gps.length} GPS_INPUT for ${rows.length} frames`);
  const state = { alignable: 0, heights: [] };
  let withFix = 0, worstPosM = 0, worstAfter = 0, worstBefore = 0, flown = 0, noFixBefore = 0;
  for (let i = 1; i < skipped; ++i) flown += Math.hypot(odo[i].x - odo[i - 1].x, odo[i].y - odo[i - 1].y);
  for (let k = 0; k < gps.length; ++k) {
    const i = k + skipped, d = gps[k], r = rows[i], who = `GPS_INPUT frame ${i} (${r.status})`;
    ardupilot(d, state, who, i);
    const expectFix = finite(d.horizAccuracy) && d.horizAccuracy <= MAX_SIGMA + 1e-6;
    check((d.fixType === 3) === expectFix, `${who}: fix_type ${d.fixType} with horiz_accuracy ${d.horizAccuracy} m, limit ${MAX_SIGMA}`);
    if (d.fixType === 3) ++withFix;
    else if (i < firstFused) ++noFixBefore;
    check(d.horizAccuracy + 1e-3 >= Math.sqrt(varianceOf[i]), `${who}: horiz_accuracy ${d.horizAccuracy} below the ODOMETRY's ${Math.sqrt(varianceOf[i])} m`);
    // The drift term restarts at a fused fix: horiz_accuracy = sqrt(variance + (DRIFT x distance
    // since the first frame or the last fused fix)^2), the distance along frames.csv's track
    // (the ODOMETRY steps, a fused fix's jump left out).
    if (fused[i] || i === 0) flown = 0;
    else flown += Math.hypot(odo[i].x - odo[i - 1].x, odo[i].y - odo[i - 1].y);
    if (k > 0) {
      const want = Math.sqrt(varianceOf[i] + (DRIFT * flown) ** 2);
      check(Math.abs(d.horizAccuracy - want) <= 0.01 + 1e-3 * want, `${who}: horiz_accuracy ${d.horizAccuracy}, expected ${want.toFixed(3)} (${flown.toFixed(2)} m since the last fix)`);
    }
    const dm = metresApart(Number(r.lat_deg), Number(r.lon_deg), d.lat / 1e7, d.lon / 1e7);
    worstPosM = Math.max(worstPosM, dm);
    check(dm <= 0.012, `${who}: ${(100 * dm).toFixed(2)} cm from frames.csv`);
    const t = truth[Number(r.frame)];
    const dTruth = metresApart(Number(t.lat_deg), Number(t.lon_deg), d.lat / 1e7, d.lon / 1e7);
    if (i < firstFused) {
      worstBefore = Math.max(worstBefore, Math.abs(dTruth - SHIFT));
      check(Math.abs(dTruth - SHIFT) <= 1.0, `${who}: ${dTruth.toFixed(2)} m from the truth before the first fix, expected ${SHIFT}`);
    } else {
      worstAfter = Math.max(worstAfter, dTruth);
      check(dTruth <= 1.5, `${who}: ${dTruth.toFixed(2)} m from the truth after the first fused fix`);
    }
  }
  check(withFix >= 3, `only ${withFix} GPS_INPUT with a 3D fix`);
  // The track geo-referenced by the SRT's fixes before the denial: their altitude (abs_alt).
  const worstAltM = checkKnownHeights(state, rows, truth);
  check(noFixBefore >= 1, 'no GPS_INPUT without a fix before the first fused fix: the drift term did not grow');
  check(withFix === gps.length - noFixBefore, `${gps.length - withFix - noFixBefore} GPS_INPUT without a fix after the first fused fix`);
  const g = summary.mavlink && summary.mavlink.gps_input;
  check(g && g.sent === gps.length && g.with_fix === withFix, `summary.json mavlink.gps_input ${JSON.stringify(g)}`);
  const m = summary.map_fixes || {};
  check(m.fused === fused.filter(Boolean).length, `summary map_fixes.fused ${m.fused}`);
  const cpu = process.cpuUsage(cpu0);
  console.log(`map + GPS_INPUT: ${rows.length} frames, ${m.attempted} attempts, ${m.fused} fixes fused ` +
              `(${resetsAtFixes} with a reset, the first a ${SHIFT} m jump), ${gps.length} GPS_INPUT (${withFix} 3D fixes) ` +
              `within ${(100 * worstPosM).toFixed(2)} cm of frames.csv; against the truth ${worstBefore.toFixed(2)} m off ${SHIFT} m before the first fix, ` +
              `within ${worstAfter.toFixed(2)} m after it, heights within ${worstAltM.toFixed(3)} m of the truth; aerovo's run ${wallS.toFixed(1)} s wall (node ${((cpu.user + cpu.system) / 1e6).toFixed(2)} s CPU)`);
}

// The run with GPS denied from the start over the true telemetry (its positions withheld): the
// map seeds the geo-reference (a whole-map search at frame 0, confirmed at frame 4, taken at
// frame 8; docs/map.md "A start without GPS"). Fails on: frames.csv not geo-referenced from
// frame 0 or with an altitude (the map gives none), summary.json enu_origin.alt_m not null, a
// GPS_INPUT before the seed or more than 1.5 m from the truth, through ArduPilot's arithmetic an
// altitude reaching EKF3 (GPS_INPUT_IGNORE_FLAG_ALT must be set on every message: no
// altitude is known), a horiz_accuracy whose drift term does not restart at the seed (1 cm) or
// a GPS_INPUT without a 3D fix.
async function runSeeded() {
  const gps = [], odo = [];
  const { sock, splitter, port } = await listen(packet => {
    if (packet.header.msgid === common.GpsInput.MSG_ID) gps.push(packet.protocol.data(packet.payload, common.GpsInput));
    if (packet.header.msgid === common.Odometry.MSG_ID) odo.push(packet.protocol.data(packet.payload, common.Odometry));
  });
  const dir = `${runDir}-seeded`;
  const args = ['run', video, '--telemetry', srtTrue, '--focal-px', focal, '--out', dir, '-q', '--no-report',
                '--mavlink', `udp:127.0.0.1:${port}`, '--mavlink-time', 'unix', '--mavlink-gps-input',
                '--mavlink-gps-input-max-sigma-m', maxSigma, '--gps-denied-after-s', '0',
                '--mavlink-gps-input-drift', String(DRIFT),
                '--map', map, '--map-fix-apply', '--map-fix-every-n-frames', '4', '--map-fix-search-radius-m', '30'];
  const wall0 = Date.now();
  const code = await runAerovo(aerovo, args);
  const wallS = (Date.now() - wall0) / 1000;
  sock.close();
  check(code === 0, `seeded: aerovo exited with ${code}`);
  check(splitter.invalidPackages === 0, `seeded: ${splitter.invalidPackages} packets with a bad CRC`);
  if (code !== 0) return;
  const rows = readCsv(path.join(dir, 'frames.csv'));
  const truth = readCsv(truthCsv);
  const summary = JSON.parse(fs.readFileSync(path.join(dir, 'summary.json'), 'utf8'));
  check(summary.heading_source === 'map', `seeded: heading_source ${summary.heading_source}`);
  check(summary.enu_origin && summary.enu_origin.alt_m === null, `seeded: enu_origin ${JSON.stringify(summary.enu_origin)}`);
  check(odo.length === rows.length, `seeded: ${odo.length} ODOMETRY for ${rows.length} frames`);
  rows.forEach((r, i) => check(r.lat_deg !== '' && r.alt_m === '', `seeded: frames.csv row ${i}: lat_deg '${r.lat_deg}', alt_m '${r.alt_m}'`));
  // GPS_INPUT from the frame the seed is taken at (the geo-reference is live from there).
  const skipped = rows.length - gps.length;
  check(skipped >= 5 && skipped <= 12, `seeded: ${gps.length} GPS_INPUT for ${rows.length} frames`);
  const state = { alignable: 0, heights: [] };
  // horiz_accuracy restarts at the seed: sqrt(ODOMETRY's variance + the seed fix's (map_fixes.csv
  // sigma_m^2 + residual_m^2, until the first fused fix) + (DRIFT x distance since the seed or
  // the last fused fix)^2); the distance from the first frame would put the seed frame's past
  // MAX_SIGMA (DRIFT x 20 m).
  const fixes = readCsv(path.join(dir, 'map_fixes.csv'));
  const seedRow = fixes.find(f => f.seed === 'confirmed');
  check(seedRow !== undefined, 'seeded: no confirmed seed in map_fixes.csv');
  let seedVar = seedRow ? Number(seedRow.sigma_m) ** 2 + Number(seedRow.residual_m) ** 2 : 0;
  const varianceOf = odo.map((o, i) => checkCovariance(Array.from(o.poseCovariance), `seeded ODOMETRY frame ${i}`, i === 0));
  let worstTruth = 0, flown = 0, withFix = 0, fusedAfter = 0, worstSigmaErr = 0;
  for (let k = 0; k < gps.length; ++k) {
    const i = k + skipped, d = gps[k], r = rows[i], who = `seeded GPS_INPUT frame ${i} (${r.status})`;
    ardupilot(d, state, who, i);
    check((d.ignoreFlags & F.ALT) !== 0, `${who}: alt ${d.alt} m sent, but the run has no altitude`);
    if (r.status.includes('+map_fix')) { flown = 0; seedVar = 0; ++fusedAfter; }
    else if (k > 0) flown += Math.hypot(odo[i].x - odo[i - 1].x, odo[i].y - odo[i - 1].y);
    const want = Math.sqrt(varianceOf[i] + seedVar + (DRIFT * flown) ** 2);
    worstSigmaErr = Math.max(worstSigmaErr, Math.abs(d.horizAccuracy - want));
    check(Math.abs(d.horizAccuracy - want) <= 0.01 + 1e-3 * want, `${who}: horiz_accuracy ${d.horizAccuracy}, expected ${want.toFixed(3)} (${flown.toFixed(2)} m since the seed or the last fused fix)`);
    if (d.fixType === 3) ++withFix;
    const t = truth[Number(r.frame)];
    const dTruth = metresApart(Number(t.lat_deg), Number(t.lon_deg), d.lat / 1e7, d.lon / 1e7);
    worstTruth = Math.max(worstTruth, dTruth);
    check(dTruth <= 1.5, `${who}: ${dTruth.toFixed(2)} m from the truth`);
  }
  checkNoHeightSent(state);
  check(gps.length > 0 && gps[0].fixType === 3, 'seeded: the seed frame\'s GPS_INPUT is not a 3D fix');
  check(withFix === gps.length, `seeded: ${gps.length - withFix} GPS_INPUT without a fix`);
  check(fusedAfter >= 2, `seeded: ${fusedAfter} fixes fused after the seed`);
  console.log(`seeded from the map: ${rows.length} frames, ${gps.length} GPS_INPUT from frame ${skipped} (no altitude; ` +
              `${withFix} 3D fixes, horiz_accuracy within ${(100 * worstSigmaErr).toFixed(2)} cm of the drift from the seed), ` +
              `within ${worstTruth.toFixed(2)} m of the truth; aerovo's run ${wallS.toFixed(1)} s wall`);
}

async function main() {
  await runShifted();
  await runSeeded();
}

finish(main, 40);
