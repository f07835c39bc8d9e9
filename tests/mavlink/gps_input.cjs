// aerovo's GPS_INPUT put through what ArduPilot does with it, decoded by node-mavlink (an
// independent MAVLink implementation), never by aerovo's code.
//   node gps_input.cjs AEROVO VIDEO SRT FOCAL_PX TRUTH_CSV MAX_SIGMA_M RUN_DIR
// VIDEO, SRT, TRUTH_CSV: a simulated flight (`aerovo simulate`: its frames as a video, its telemetry with
// the camera's yaw, its ground_truth.csv) with a black frame mid-flight (bridged, then
// re-acquired). `aerovo run VIDEO --telemetry SRT --gps-denied-after-s 1 --focal-px FOCAL_PX --mavlink
// udp:... --mavlink-gps-input --mavlink-gps-input-max-sigma-m MAX_SIGMA_M --mavlink-time unix`
// sends to this script, which applies, to every GPS_INPUT, what these ArduPilot functions do
// (docs/autopilot.md "GPS_INPUT: what ArduPilot does with each field"):
//   AP_GPS_MAV::handle_msg (libraries/AP_GPS/AP_GPS_MAV.cpp): the ignore flags, location from
//     lat/lon (alt x 100 -> cm), hdop x 100 -> uint16 cm, velocity (vn, ve; vd ignored) to
//     ground course and speed, the accuracies, yaw (0 = none, else wrap_360(yaw x 0.01)), the
//     GPS time ((week - first week) x ms per week + week ms, uint32) into the jitter correction
//     when fix_type >= 3 and time_week > 0, satellites;
//   NavEKF3_core::readGpsData (AP_NavEKF3_Measurements.cpp): only a 3D fix is used; hAcc and
//     sAcc capped at 100 m and 50 m/s; the origin's height and, with EK3_SRC1_POSZ = 3, every
//     fix's height from the Location's alt (0 when GPS_INPUT_IGNORE_FLAG_ALT is set);
//   NavEKF3_core::calcGpsGoodToAlign (AP_NavEKF3_VehicleStatus.cpp): a 3D fix must pass its
//     satellite (>= 6) and HDOP (<= 2.5) checks (the fixes within its hAcc 5 m are counted).
// Fails on any NaN or out-of-range value reaching that arithmetic, on a position more than
// 1.2 cm from frames.csv's lat/lon (degE7 quantises to 1.1 cm) or 0.5 m from the truth's, on a
// GPS time that is not the message's Unix time as ArduPilot converts it back (18 leap seconds)
// or whose differences are not the frames' (1 ms), on a fix type that disagrees with
// horiz_accuracy against MAX_SIGMA_M, and on a velocity more than 5 % of the speed off the
// simulator's (ground_truth.csv, between consecutive measured frames) or a yaw more than 2
// degrees off its yaw, and on a height reaching EKF3 more than 0.5 m off the truth's altitude
// (the track geo-referenced by GPS fixes with an altitude, SRT abs_alt). Exit 0 = pass, 1 = fail
// (the reasons printed).
'use strict';
const fs = require('fs');
const path = require('path');
const { common } = require('node-mavlink');
const { failures, check, readCsv, listen, runAerovo, finish } = require('./harness.cjs');

const [aerovo, frames, srt, focal, truthCsv, maxSigma, runDir] = process.argv.slice(2);
const MAX_SIGMA = Number(maxSigma);
const finite = v => typeof v === 'number' && Number.isFinite(v);
const MS_PER_WEEK = 604800000;
// ArduPilot's GPS time to Unix time (AP_GPS.h): 1980-01-06 less the 18 leap seconds.
const UNIX_OFFSET_MSEC = 17000 * 86400 + 52 * 10 * MS_PER_WEEK - 18000;
// GPS_INPUT_IGNORE_FLAGS (common.xml).
const F = { ALT: 1, HDOP: 2, VDOP: 4, VEL_HORIZ: 8, VEL_VERT: 16, SPEED_ACC: 32, HACC: 64, VACC: 128 };
const wrap360 = d => ((d % 360) + 360) % 360;
const angleDiff = (a, b) => Math.abs(((a - b + 540) % 360) - 180);
// Metres between two WGS84 points a few metres apart (equirectangular, Earth radius 6378137 m).
function metresApart(lat1, lon1, lat2, lon2) {
  const r = 6378137, k = Math.PI / 180;
  const dn = (lat2 - lat1) * k * r, de = (lon2 - lon1) * k * r * Math.cos(lat1 * k);
  return Math.hypot(dn, de);
}

// ArduPilot's AP_GPS_MAV::handle_msg and EKF3's use of the resulting state, for one message
// (of frames.csv's row `row`, for state.heights).
function ardupilot(d, state, who, row) {
  const has = f => (d.ignoreFlags & f) === 0;
  const s = { status: d.fixType, lat: d.lat, lng: d.lon };
  // Recent master drops a gps_id other than the instance's index: GPS1_TYPE 14 is instance 0.
  check(d.gpsId === 0, `${who}: gps_id ${d.gpsId}, not the first GPS instance`);
  check(Number.isInteger(d.lat) && Math.abs(d.lat) <= 900000000 && Math.abs(d.lon) <= 1800000000, `${who}: lat/lon ${d.lat}/${d.lon} out of range`);
  // The Location is zero-initialised: alt x 100 (cm) only when the flag is clear, else 0.
  s.altCm = 0;
  if (has(F.ALT)) { s.altCm = d.alt * 100; check(finite(s.altCm) && Math.abs(s.altCm) < 2 ** 31, `${who}: alt ${d.alt}`); }
  if (has(F.HDOP)) { s.hdopCm = d.hdop * 100; check(finite(s.hdopCm) && s.hdopCm >= 0 && s.hdopCm <= 65535, `${who}: hdop ${d.hdop} does not fit AP_GPS's uint16 cm`); }
  if (has(F.VDOP)) { s.vdopCm = d.vdop * 100; check(finite(s.vdopCm) && s.vdopCm >= 0 && s.vdopCm <= 65535, `${who}: vdop ${d.vdop}`); }
  if (has(F.VEL_HORIZ)) {
    s.vel = [d.vn, d.ve, has(F.VEL_VERT) ? d.vd : 0];
    check(s.vel.every(finite), `${who}: velocity ${s.vel}`);
    s.groundCourse = wrap360(Math.atan2(d.ve, d.vn) * 180 / Math.PI);
    s.groundSpeed = Math.hypot(d.vn, d.ve);
  }
  check(!has(F.VEL_VERT), `${who}: vd sent but aerovo does not measure vertical speed`);
  check(!has(F.VACC), `${who}: vert_accuracy sent but aerovo does not measure height`);
  if (has(F.SPEED_ACC)) { s.sAcc = d.speedAccuracy; check(finite(s.sAcc) && s.sAcc >= 0, `${who}: speed_accuracy ${s.sAcc}`); }
  if (has(F.HACC)) { s.hAcc = d.horizAccuracy; check(finite(s.hAcc) && s.hAcc >= 0, `${who}: horiz_accuracy ${s.hAcc}`); }
  check(d.yaw <= 36000, `${who}: yaw ${d.yaw} cdeg above 36000`);
  if (d.yaw !== 0) s.gpsYaw = wrap360(d.yaw * 0.01);
  if (d.fixType >= 3 && d.timeWeek > 0) {
    if (state.firstWeek === undefined) state.firstWeek = d.timeWeek;
    // uint32 arithmetic, as ArduPilot's.
    s.timestampMs = ((d.timeWeek - state.firstWeek) * MS_PER_WEEK + d.timeWeekMs) >>> 0;
    check(d.timeWeekMs < MS_PER_WEEK, `${who}: time_week_ms ${d.timeWeekMs} beyond a week`);
  }
  s.numSats = d.satellitesVisible;
  // EKF3 readGpsData: only a 3D fix; accuracies capped.
  if (d.fixType >= 3) {
    const posAcc = Math.min(s.hAcc ?? 0, 100), spdAcc = Math.min(s.sAcc ?? 0, 50);
    check(finite(posAcc) && finite(spdAcc), `${who}: EKF3 accuracies ${posAcc} ${spdAcc}`);
    // calcGpsGoodToAlign: satellites and HDOP must pass for EKF3 to start using the fix.
    check(s.numSats >= 6, `${who}: ${s.numSats} satellites: EKF3 will not align (needs 6)`);
    check(s.hdopCm !== undefined && s.hdopCm <= 250, `${who}: HDOP ${d.hdop}: EKF3 will not align (needs 2.5)`);
    if (s.hAcc <= 5) ++state.alignable;
    // readGpsData: the origin's height (ekfGpsRefHgt) from the first fix's Location alt, then
    // every fix's height against it, fused with EK3_SRC1_POSZ = 3 (GPS): the heights the
    // estimator gets, and whether each was sent (else ArduPilot's 0 from the ignore flag).
    if (state.heights) state.heights.push({ m: s.altCm / 100, sent: has(F.ALT), who, row });
  }
  return s;
}

async function main() {
  const msgs = [];
  const { sock, splitter, port } = await listen(packet => {
    if (packet.header.msgid !== common.GpsInput.MSG_ID) return;
    msgs.push(packet.protocol.data(packet.payload, common.GpsInput));
  });
  const args = ['run', frames, '--telemetry', srt, '--focal-px', focal, '--out', runDir, '-q', '--no-report', '--mavlink', `udp:127.0.0.1:${port}`,
                '--mavlink-time', 'unix', '--mavlink-gps-input', '--mavlink-gps-input-max-sigma-m', maxSigma,
                // GPS off after take-off: from 1 s on, GPS_INPUT carries aerovo's own position.
                '--gps-denied-after-s', '1'];
  const startMs = Date.now();
  const code = await runAerovo(aerovo, args);
  const endMs = Date.now();
  sock.close();
  check(code === 0, `aerovo exited with ${code}`);
  check(splitter.invalidPackages === 0, `${splitter.invalidPackages} packets with a bad CRC`);
  if (code !== 0) return;
  const rows = readCsv(path.join(runDir, 'frames.csv'));
  const truth = readCsv(truthCsv);
  const summary = JSON.parse(fs.readFileSync(path.join(runDir, 'summary.json'), 'utf8'));
  // One GPS_INPUT per frame from the first geo-referenced one on (the heading known: with the
  // telemetry's yaw, once the first 3 fixes agree, GpsCheckOptions::min_chain): the last frames.
  const skipped = rows.length - msgs.length;
  check(skipped >= 0 && skipped <= 3, `${msgs.length} GPS_INPUT for ${rows.length} frames`);
  const n = msgs.length;
  const state = { alignable: 0, heights: [] };
  let withFix = 0, worstPosM = 0, worstVel = 0, nVel = 0, worstYaw = 0, bridged = 0, reacquired = 0;
  let speedSum = 0, worstTruthM = 0;
  for (let k = 0; k < n; ++k) {
    const i = k + skipped;
    const d = msgs[k], r = rows[i], who = `GPS_INPUT frame ${i} (${r.status})`;
    if (r.status.startsWith('bridged')) ++bridged;
    if (r.status === 'reacquired') ++reacquired;
    const s = ardupilot(d, state, who, i);
    // The fix type follows the accuracy and the limit.
    const expectFix = finite(d.horizAccuracy) && d.horizAccuracy <= MAX_SIGMA + 1e-6;
    check((d.fixType === 3) === expectFix, `${who}: fix_type ${d.fixType} with horiz_accuracy ${d.horizAccuracy} m, limit ${MAX_SIGMA}`);
    if (d.fixType === 3) ++withFix;
    check(d.fixType === 3 || d.fixType === 1, `${who}: fix_type ${d.fixType}`);
    // The position: frames.csv's lat/lon.
    const dm = metresApart(Number(r.lat_deg), Number(r.lon_deg), d.lat / 1e7, d.lon / 1e7);
    worstPosM = Math.max(worstPosM, dm);
    check(dm <= 0.012, `${who}: ${(100 * dm).toFixed(2)} cm from frames.csv`);
    // And from the simulator's truth (the odometry's error since the geo-reference: the SRT's
    // fixes are rounded to 1e-6 degrees, 0.1 m).
    const tt = truth[Number(r.frame)];
    const dTruth = metresApart(Number(tt.lat_deg), Number(tt.lon_deg), d.lat / 1e7, d.lon / 1e7);
    worstTruthM = Math.max(worstTruthM, dTruth);
    check(dTruth <= 0.5, `${who}: ${dTruth.toFixed(3)} m from the simulator's truth`);
    // GPS time back to UTC as ArduPilot does for its clock (AP_GPS.h UNIX_OFFSET_MSEC, with
    // GPS_LEAPSECONDS_MILLIS 18000): the message's Unix time (time_usec, --mavlink-time unix),
    // within the run; differences the frames' own.
    const gpsMs = d.timeWeek * MS_PER_WEEK + d.timeWeekMs;
    const unixMs = Number(d.timeUsec) / 1000;
    check(Math.abs(UNIX_OFFSET_MSEC + gpsMs - unixMs) <= 1, `${who}: GPS time ${gpsMs} ms is ${UNIX_OFFSET_MSEC + gpsMs - unixMs} ms off time_usec in UTC`);
    check(unixMs >= startMs - 1000 && unixMs <= endMs + 60000, `${who}: Unix time ${unixMs} ms outside the run (${startMs}..${endMs})`);
    if (k > 0) {
      const p = msgs[k - 1];
      const dtMsg = (gpsMs - (p.timeWeek * MS_PER_WEEK + p.timeWeekMs)) / 1000;
      const dtFrames = Number(r.time_s) - Number(rows[i - 1].time_s);
      check(Math.abs(dtMsg - dtFrames) <= 1e-3, `${who}: GPS times ${dtMsg} s apart, the frames ${dtFrames} s`);
    }
    // Velocity and yaw against the simulator's truth.
    const t = truth[Number(r.frame)];
    if (i > 0 && r.status === 'ok' && (rows[i - 1].status === 'ok' || rows[i - 1].status === 'first') && s.vel) {
      const tp = truth[Number(rows[i - 1].frame)];
      const dt = Number(t.time_s) - Number(tp.time_s);
      const vTrue = [(Number(t.north_m) - Number(tp.north_m)) / dt, (Number(t.east_m) - Number(tp.east_m)) / dt];
      const speed = Math.hypot(...vTrue);
      speedSum += speed;
      const err = Math.hypot(s.vel[0] - vTrue[0], s.vel[1] - vTrue[1]) / speed;
      worstVel = Math.max(worstVel, err);
      ++nVel;
      check(err <= 0.05, `${who}: velocity N ${d.vn.toFixed(3)} E ${d.ve.toFixed(3)}, truth ${vTrue.map(v => v.toFixed(3))}: ${(100 * err).toFixed(1)} %`);
    }
    if (i === 0) check((d.ignoreFlags & F.VEL_HORIZ) !== 0, `${who}: the first frame has no velocity`);
    else check((d.ignoreFlags & F.VEL_HORIZ) === 0, `${who}: no velocity`);
    check(s.gpsYaw !== undefined, `${who}: no yaw while the track is geo-referenced`);
    if (s.gpsYaw !== undefined) {
      const e = angleDiff(s.gpsYaw, Number(t.yaw_deg));
      worstYaw = Math.max(worstYaw, e);
      check(e <= 2, `${who}: yaw ${s.gpsYaw} deg, truth ${t.yaw_deg}`);
    }
  }
  const worstAltM = checkKnownHeights(state, rows, truth);
  const denied = rows.filter(r => r.gps_flag === 'withheld').length;
  check(denied >= rows.length - 6, `only ${denied} of ${rows.length} frames without GPS`);
  check(bridged >= 1 && reacquired >= 1, `the flight must bridge and re-acquire (bridged ${bridged}, reacquired ${reacquired})`);
  check(withFix >= 3 && n - withFix >= 3, `both 3D fixes and no-fix messages expected (limit ${MAX_SIGMA} m): ${withFix} of ${n} with a fix`);
  check(nVel >= 5, `only ${nVel} velocities checked`);
  const g = summary.mavlink && summary.mavlink.gps_input;
  check(g && g.sent === n && g.with_fix === withFix && g.without_fix === n - withFix,
        `summary.json mavlink.gps_input ${JSON.stringify(g)}: ${n} sent, ${withFix} with a fix`);
  console.log(`GPS_INPUT: ${n} messages, ${withFix} 3D fixes (${state.alignable} within EKF3's 5 m), ` +
              `positions within ${(100 * worstPosM).toFixed(2)} cm of frames.csv and ${worstTruthM.toFixed(3)} m of the truth, ${nVel} velocities ` +
              `within ${(100 * worstVel).toFixed(2)} % of the truth (${(speedSum / Math.max(1, nVel)).toFixed(2)} m/s), yaw within ${worstYaw.toFixed(2)} deg, ` +
              `heights within ${worstAltM.toFixed(3)} m of the truth`);
}

// The heights EKF3 got (state.heights, one per 3D fix) when the run knows its altitude: every
// one sent and within 0.5 m of the truth's alt_m (truth CSV) at its frame. The worst, m.
function checkKnownHeights(state, rows, truth) {
  let worst = 0;
  check(state.heights.length >= 1, 'no height reached EKF3');
  for (const h of state.heights) {
    const want = Number(truth[Number(rows[h.row].frame)].alt_m);
    worst = Math.max(worst, Math.abs(h.m - want));
    check(h.sent && Math.abs(h.m - want) <= 0.5, `${h.who}: EKF3's GPS height ${h.m} m (sent: ${h.sent}), the truth ${want} m`);
  }
  return worst;
}

// The heights EKF3 got when the run has no altitude (a track placed by a map, GPS never): none
// may have been sent (GPS_INPUT_IGNORE_FLAG_ALT on every message), so that what reaches the
// estimator is ArduPilot's own 0 of an ignored altitude, never an invented one.
function checkNoHeightSent(state) {
  check(state.heights.length >= 1, 'no 3D fix reached EKF3');
  for (const h of state.heights) check(!h.sent, `${h.who}: an altitude ${h.m} m reached EKF3, but the run has none`);
}

// map_gps_input.cjs reuses ArduPilot's arithmetic; run as a script, the check above.
module.exports = { ardupilot, metresApart, checkKnownHeights, checkNoHeightSent, MS_PER_WEEK, UNIX_OFFSET_MSEC, F };
if (require.main === module) finish(main, 40);
