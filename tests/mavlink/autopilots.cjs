// aerovo's vision messages put through the arithmetic of the two autopilots that consume them,
// decoded by node-mavlink (an independent MAVLink implementation), never by aerovo's code.
//   node autopilots.cjs AEROVO VIDEO FOCAL_PX HEIGHT_M SPEED_MPS RUN_DIR
// VIDEO: a simulated straight flight (yaw following the track, SPEED_MPS, HEIGHT_M) with a
// black frame mid-flight (bridged, then re-acquired). For each of ODOMETRY,
// VISION_POSITION_ESTIMATE and VISION_POSITION_DELTA, `aerovo run VIDEO --mavlink udp:...` sends
// to this script, which applies what each autopilot does with every message (docs/autopilot.md
// "What ArduPilot and PX4 do with each field", the receivers read there):
//   ArduPilot: GCS_Common.cpp handle_odometry / handle_common_vision_position_estimate_data
//     (posErr = cbrt(cov[0]^2 + cov[6]^2 + cov[11]^2), angErr from [15], [18], [20], computed
//     when cov[0] is not NaN), AP_VisualOdom's constrain_float(posErr, VISO_POS_M_NSE, 100) and
//     (angErr, VISO_YAW_M_NSE, 1.5) (a NaN there is an internal error), VISO_QUAL_MIN 0,
//     reset_counter as VISO_TYPE 3 reads it, the velocity rotated by q and dropped by EKF3 when
//     NaN; VISION_POSITION_DELTA through EKF3 writeBodyFrameOdom (NaN guard, time delta at
//     least one EKF step, velocity = delta / time, error from confidence in 0-100).
//   PX4: mavlink_receiver.cpp handle_message_odometry (variances [0] [6] [11], [15] [18] [20],
//     velocity variances [0] [6] [11]) and EKF2 UpdateExtVisionSample with EKF2_EV_NOISE_MD 0
//     (a variance vector is used only when all its elements are finite, else the parameters
//     silently replace it; position, velocity and q used only when all finite, q of unit norm),
//     quality against EKF2_EV_QMIN 0, reset_counter changes as resets.
// Fails on any NaN or non-finite value reaching that arithmetic (but the first frame's velocity,
// which both drop by design), on a covariance either would replace by its parameters, on a
// position (x, y) that differs from frames.csv by more than 1 mm under the documented axes
// (x_frd = y_local, y_frd = x_local), on a timestamp difference that is not the frames' own
// (frames.csv time_s, 1 ms), and on a velocity more than 5 % off SPEED_MPS along the track.
// Exit 0 = pass, 1 = fail (the reasons printed).
'use strict';
const path = require('path');
const { minimal, common, ardupilotmega } = require('node-mavlink');
const { failures, check, readCsv, listen, runAerovo, finish } = require('./harness.cjs');

const [aerovo, video, focal, heightM, speedMps, runRoot] = process.argv.slice(2);
const SPEED = Number(speedMps);
const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY, ...ardupilotmega.REGISTRY };
const finite = v => typeof v === 'number' && Number.isFinite(v);
const allFinite = a => a.every(finite);

// The autopilots' defaults used below.
const VISO_POS_M_NSE = 0.2, VISO_YAW_M_NSE = 0.2, VISO_QUAL_MIN = 0;  // ArduPilot AP_VisualOdom
const EKF3_DT_MIN_S = 0.0025;  // the smallest EKF3 step (400 Hz loop) a delta must span
const EKF2_EVP_NOISE = 0.1, EKF2_EVV_NOISE = 0.1, EKF2_EVA_NOISE = 0.05, EKF2_EV_QMIN = 0;

// ArduPilot's constrain_value_line (AP_Math.cpp): a NaN is an internal error.
function apConstrain(v, lo, hi, what) {
  if (Number.isNaN(v)) { failures.push(`ArduPilot: constrain of a NaN (internal error): ${what}`); return (lo + hi) / 2; }
  return Math.min(hi, Math.max(lo, v));
}
// ArduPilot's covariance to errors (GCS_Common.cpp), then the backend's clamps.
function apErrors(cov, what) {
  let posErr = 0, angErr = 0;
  if (!Number.isNaN(cov[0])) {
    posErr = Math.cbrt(cov[0] ** 2 + cov[6] ** 2 + cov[11] ** 2);
    angErr = Math.cbrt(cov[15] ** 2 + cov[18] ** 2 + cov[20] ** 2);
  }
  return { posErr: apConstrain(posErr, VISO_POS_M_NSE, 100, `${what} posErr`),
           angErr: apConstrain(angErr, VISO_YAW_M_NSE, 1.5, `${what} angErr`) };
}
// Rotates v (body) by the unit quaternion q = (w, x, y, z): local = q * v * q^-1.
function rotate(q, v) {
  const [w, x, y, z] = q;
  const m = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
             [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
             [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]];
  return m.map(r => r[0] * v[0] + r[1] * v[1] + r[2] * v[2]);
}
const quatOfEuler = (r, p, y) => {
  const cr = Math.cos(r / 2), sr = Math.sin(r / 2), cp = Math.cos(p / 2), sp = Math.sin(p / 2),
        cy = Math.cos(y / 2), sy = Math.sin(y / 2);
  return [cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
          cr * cp * sy - sr * sp * cy];
};
const norm = a => Math.sqrt(a.reduce((s, v) => s + v * v, 0));

// The velocity a consumer fuses, in the start's FRD frame, against the simulator's: a straight
// track along the first image's up (forward), SPEED m/s.
function checkVelocity(who, i, vLocal) {
  const err = norm([vLocal[0] - SPEED, vLocal[1], vLocal[2]]);
  check(err <= 0.05 * SPEED, `${who} frame ${i}: velocity (${vLocal.map(v => v.toFixed(3))}) is ${(100 * err / SPEED).toFixed(1)} % off ${SPEED} m/s forward`);
  return err / SPEED;
}

async function runOnce(kind) {
  const runDir = path.join(runRoot, kind);
  const msgs = [];
  const { sock, splitter, port } = await listen(packet => {
    const clazz = REGISTRY[packet.header.msgid];
    if (!clazz || packet.header.msgid === minimal.Heartbeat.MSG_ID) return;
    msgs.push({ id: packet.header.msgid, d: packet.protocol.data(packet.payload, clazz) });
  });
  const args = ['run', video, '--focal-px', focal, '--altitude', heightM, '--out', runDir, '-q',
                '--no-report', '--mavlink', `udp:127.0.0.1:${port}`, '--mavlink-message', kind];
  const code = await runAerovo(aerovo, args);
  sock.close();
  check(code === 0, `${kind}: aerovo exited with ${code}`);
  check(splitter.invalidPackages === 0, `${kind}: ${splitter.invalidPackages} packets with a bad CRC`);
  const rows = code === 0 ? readCsv(path.join(runDir, 'frames.csv')) : [];
  check(msgs.length === rows.length, `${kind}: ${msgs.length} messages for ${rows.length} frames`);
  return { msgs: msgs.map(m => m.d), rows };
}

// Per message: the frames.csv row's position (FRD x, y), the time difference to the previous
// frame, the status.
function expectOf(rows, i) {
  const r = rows[i];
  return { x: Number(r.y_m), y: Number(r.x_m), t: Number(r.time_s), status: r.status,
           dt: i > 0 ? Number(r.time_s) - Number(rows[i - 1].time_s) : 0 };
}
// Frames whose velocity is a measured step from a measured (or the first) frame.
const velocityChecked = (rows, i) => i > 0 && rows[i].status === 'ok' &&
  (rows[i - 1].status === 'ok' || rows[i - 1].status === 'first');

// A live source's frames are placed on the clock by the least delayed frame so far
// (docs/autopilot.md, "Times"): a frame that arrives with less delay than all before moves the
// clock earlier, so a timestamp difference may be shorter than the frames' own by that much
// (never longer), at most clockSlack.s (0 for files; live.cjs sets it).
const clockSlack = { s: 0, used: 0 };

function checkCommon(who, rows, msgs, timeOf) {
  let reacquired = 0, bridged = 0;
  for (let i = 0; i < Math.min(rows.length, msgs.length); ++i) {
    if (rows[i].status === 'reacquired') ++reacquired;
    if (rows[i].status.startsWith('bridged')) ++bridged;
    if (i === 0) continue;
    const dtSent = Number(timeOf(msgs[i]) - timeOf(msgs[i - 1])) * 1e-6;
    const dtOwn = expectOf(rows, i).dt;
    const earlier = dtOwn - dtSent;
    if (earlier > 1e-3) clockSlack.used = Math.max(clockSlack.used, earlier);
    check(dtSent > 0 && earlier >= -1e-3 && earlier <= clockSlack.s + 1e-3,
      `${who} frame ${i}: timestamps ${dtSent.toFixed(4)} s apart, the frames ${dtOwn.toFixed(4)} s`);
  }
  check(reacquired >= 1 && bridged >= 1, `${who}: the flight must bridge and re-acquire (bridged ${bridged}, reacquired ${reacquired})`);
}

function odometry({ msgs, rows }) {
  checkCommon('ODOMETRY', rows, msgs, d => d.timeUsec);
  let apReset = 0, px4Reset = 0, worst = 0, nVel = 0, apPosErrMax = 0;
  msgs.forEach((d, i) => {
    if (i >= rows.length) return;
    const e = expectOf(rows, i), who = `ODOMETRY frame ${i} (${e.status})`;
    const measured = !e.status.startsWith('bridged');
    // ArduPilot, handle_odometry.
    check(d.frameId === 20 && d.childFrameId === 12, `${who}: frames ${d.frameId}/${d.childFrameId}, ArduPilot drops all but LOCAL_FRD/BODY_FRD`);
    const q = d.q;
    check(allFinite(q) && Math.abs(norm(q) - 1) < 1e-4, `${who}: q ${q} not a unit quaternion`);
    const { posErr } = apErrors(d.poseCovariance, who);
    apPosErrMax = Math.max(apPosErrMax, posErr);
    const apFused = d.quality >= VISO_QUAL_MIN;
    check(apFused === measured, `${who}: quality ${d.quality}, ArduPilot fuses it: ${apFused}`);
    if (d.resetCounter !== apReset) {
      check(d.resetCounter === ((apReset + 1) & 255) && e.status === 'reacquired', `${who}: reset_counter ${apReset} -> ${d.resetCounter}`);
      apReset = d.resetCounter;
    } else {
      check(e.status !== 'reacquired', `${who}: re-acquired without a reset_counter change`);
    }
    check(Math.abs(d.x - e.x) <= 1e-3 && Math.abs(d.y - e.y) <= 1e-3, `${who}: position (${d.x}, ${d.y}), frames.csv (${e.x}, ${e.y})`);
    check(finite(d.z), `${who}: z ${d.z}`);
    const vBody = [d.vx, d.vy, d.vz];
    if (i === 0) {
      check(vBody.every(Number.isNaN), `${who}: the first frame has no velocity, got ${vBody}`);
    } else {
      check(allFinite(vBody), `${who}: velocity ${vBody}: EKF3 writeExtNavVelData and EKF2 drop it`);
    }
    // PX4, handle_message_odometry + UpdateExtVisionSample (EKF2_EV_NOISE_MD 0).
    check(d.estimatorType === 2, `${who}: estimator_type ${d.estimatorType}, PX4 publishes VISION (2) as visual odometry`);
    const posVar = [0, 6, 11].map(k => d.poseCovariance[k]);
    const oriVar = [15, 18, 20].map(k => d.poseCovariance[k]);
    check(allFinite([d.x, d.y, d.z]), `${who}: PX4 needs x, y, z all finite`);
    check(allFinite(posVar) && posVar.every(v => v >= 0), `${who}: position variances ${posVar}: PX4 would use EKF2_EVP_NOISE instead`);
    check(allFinite(oriVar) && oriVar.every(v => v >= 0), `${who}: orientation variances ${oriVar}: PX4 would use EKF2_EVA_NOISE instead`);
    // ev_pos_control.cpp, LOCAL_FRD without EV yaw: the horizontal variance at least the largest
    // orientation variance, then at least EKF2_EVP_NOISE^2.
    const oriMax = Math.max(...oriVar.map(v => Math.max(EKF2_EVA_NOISE ** 2, v)));
    const hVar = [0, 1].map(k => Math.max(posVar[k], oriMax, EKF2_EVP_NOISE ** 2, 1e-4));
    check(allFinite(hVar), `${who}: PX4 horizontal position variance ${hVar}`);
    if (i > 0) {
      const velVar = [0, 6, 11].map(k => d.velocityCovariance[k]);
      check(allFinite(velVar) && velVar.every(v => v >= 0), `${who}: velocity variances ${velVar}: PX4 would use EKF2_EVV_NOISE instead`);
      check(allFinite(velVar.map(v => Math.max(EKF2_EVV_NOISE ** 2, v))), `${who}: PX4 velocity variance`);
    } else {
      check(Number.isNaN(d.velocityCovariance[0]), `${who}: the unknown velocity covariance has NaN first`);
    }
    const px4Fused = d.quality >= EKF2_EV_QMIN;
    check(px4Fused === measured, `${who}: quality ${d.quality}, PX4 fuses it: ${px4Fused}`);
    if (d.resetCounter !== px4Reset) px4Reset = d.resetCounter;
    if (velocityChecked(rows, i)) {
      // ArduPilot: vel = q * v (local FRD); PX4 BODY_FRD, rotated by its own attitude (= q here).
      worst = Math.max(worst, checkVelocity('ODOMETRY', i, rotate(q, vBody)));
      ++nVel;
    }
  });
  check(nVel >= 5, `ODOMETRY: only ${nVel} velocities checked`);
  console.log(`ODOMETRY: ${msgs.length} messages, ArduPilot posErr up to ${apPosErrMax.toFixed(3)} m, ` +
              `${nVel} velocities within ${(100 * worst).toFixed(2)} % of ${SPEED} m/s`);
}

function positionEstimate({ msgs, rows }) {
  checkCommon('VISION_POSITION_ESTIMATE', rows, msgs, d => d.usec);
  let reset = 0;
  msgs.forEach((d, i) => {
    if (i >= rows.length) return;
    const e = expectOf(rows, i), who = `VISION_POSITION_ESTIMATE frame ${i} (${e.status})`;
    // ArduPilot handle_common_vision_position_estimate_data: position, euler, covariance, reset.
    check(allFinite([d.x, d.y, d.z, d.roll, d.pitch, d.yaw]), `${who}: non-finite pose`);
    const q = quatOfEuler(d.roll, d.pitch, d.yaw);
    check(allFinite(q), `${who}: attitude`);
    apErrors(d.covariance, who);
    // PX4 reads the same variances ([0] [6] [11], [15] [18] [20]).
    const vars = [0, 6, 11, 15, 18, 20].map(k => d.covariance[k]);
    check(allFinite(vars) && vars.every(v => v >= 0), `${who}: variances ${vars}`);
    check(Math.abs(d.x - e.x) <= 1e-3 && Math.abs(d.y - e.y) <= 1e-3, `${who}: position (${d.x}, ${d.y}), frames.csv (${e.x}, ${e.y})`);
    if (d.resetCounter !== reset) {
      check(d.resetCounter === ((reset + 1) & 255) && e.status === 'reacquired', `${who}: reset_counter ${reset} -> ${d.resetCounter}`);
      reset = d.resetCounter;
    }
  });
  console.log(`VISION_POSITION_ESTIMATE: ${msgs.length} messages`);
}

function positionDelta({ msgs, rows }) {
  checkCommon('VISION_POSITION_DELTA', rows, msgs, d => d.timeUsec);
  let worst = 0, nVel = 0, yaw = 0;
  msgs.forEach((d, i) => {
    if (i >= rows.length) return;
    const e = expectOf(rows, i), who = `VISION_POSITION_DELTA frame ${i} (${e.status})`;
    // EKF3 writeBodyFrameOdom: NaN guard, then dropped when the time delta is under an EKF step.
    const values = [...d.positionDelta, ...d.angleDelta, d.confidence];
    check(allFinite(values), `${who}: non-finite ${values}`);
    check(d.confidence >= 0 && d.confidence <= 100, `${who}: confidence ${d.confidence} outside 0-100 (EKF3's velocity error interpolates over it)`);
    const delTime = Number(d.timeDeltaUsec) * 1e-6;
    if (i === 0) {
      check(delTime < EKF3_DT_MIN_S, `${who}: the first frame has no delta, time_delta ${delTime}`);
      return;
    }
    check(Math.abs(delTime - e.dt) <= 1e-3, `${who}: time_delta ${delTime} s, the frames ${e.dt} s apart`);
    check(delTime >= EKF3_DT_MIN_S, `${who}: time_delta ${delTime} s shorter than an EKF3 step`);
    // The move in the previous body frame, turned back by the previous yaw: frames.csv's step.
    const p = expectOf(rows, i - 1);
    const c = Math.cos(yaw), s = Math.sin(yaw);
    const [bx, by] = d.positionDelta;
    const step = [c * bx - s * by, s * bx + c * by];
    check(Math.abs(step[0] - (e.x - p.x)) <= 1e-3 && Math.abs(step[1] - (e.y - p.y)) <= 1e-3,
      `${who}: delta turned back (${step}), frames.csv step (${e.x - p.x}, ${e.y - p.y})`);
    yaw += d.angleDelta[2];
    if (velocityChecked(rows, i)) {
      worst = Math.max(worst, checkVelocity('VISION_POSITION_DELTA', i, d.positionDelta.map(v => v / delTime)));
      ++nVel;
    }
  });
  check(nVel >= 5, `VISION_POSITION_DELTA: only ${nVel} velocities checked`);
  console.log(`VISION_POSITION_DELTA: ${msgs.length} messages, ${nVel} velocities within ${(100 * worst).toFixed(2)} % of ${SPEED} m/s`);
}

async function main() {
  odometry(await runOnce('odometry'));
  positionEstimate(await runOnce('vision_position_estimate'));
  positionDelta(await runOnce('vision_position_delta'));
}

// Run as a script: the file's three runs. Loaded by live.cjs (the same arguments, VIDEO then a
// stream): the per-consumer checks of one run's messages and frames.csv rows.
if (require.main === module) finish(main, 40);
else module.exports = { REGISTRY, odometry, positionEstimate, clockSlack };
