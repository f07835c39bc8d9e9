// aerovo's MAVLink output checked by node-mavlink, an independent MAVLink implementation.
//   node e2e.cjs udp   AEROVO FRAMES_DIR FOCAL_PX HEIGHT_M RUN_DIR
//     aerovo run FRAMES_DIR --mavlink udp:127.0.0.1:PORT (this script listens on PORT): one
//     ODOMETRY per processed frame with a valid CRC, timestamps strictly increasing, positions
//     equal to frames.csv within 1 mm under docs/autopilot.md's conversion (x_frd = y_local,
//     y_frd = x_local), quality -1 exactly on bridged frames, reset_counter + 1 on every
//     re-acquired frame, a HEARTBEAT from sysid 3 / compid 197; with --mavlink-gps-input but no
//     telemetry (the track is never geo-referenced) no GPS_INPUT at all, and summary.json's
//     mavlink.gps_input says 0 sent (gps_input.cjs checks a geo-referenced flight's).
//   node e2e.cjs udpin AEROVO FRAMES_DIR FOCAL_PX HEIGHT_M RUN_DIR
//     a fake autopilot: aerovo run FRAMES_DIR --mavlink udpin:127.0.0.1:PORT without
//     --altitude; this script sends DISTANCE_SENSOR (HEIGHT_M, facing down) and ATTITUDE at
//     50 Hz and a TIMESYNC request: the run must use that height (frames.csv height_m,
//     height_source, roll/pitch; summary.json), answer the TIMESYNC and send its ODOMETRY here.
//   node e2e.cjs signed AEROVO FRAMES_DIR FOCAL_PX HEIGHT_M RUN_DIR
//     as udpin with --mavlink-key (a random key, 64 hex digits, mode 600) and node-mavlink's own
//     signing on both sides: the fake autopilot signs what it sends, and also sends DISTANCE_SENSOR
//     forged (signed with another key), unsigned, replayed (a copy of one already sent) and
//     captured (signed with the key but older than what was sent since), each with another
//     height: the run must use only HEIGHT_M and count them in summary.json; every packet of
//     aerovo must carry a signature that node-mavlink verifies with the key, timestamps strictly
//     increasing. Before that, the same run with the key file in mode 644 must exit 1 naming it.
// Exit 0 = pass, 1 = fail (the reasons printed).
'use strict';
const dgram = require('dgram');
const fs = require('fs');
const path = require('path');
const { spawnSync } = require('child_process');
const crypto = require('crypto');
const { MavLinkProtocolV2, minimal, common } = require('node-mavlink');
const { failures, check, readCsv, listen, runAerovo, finish } = require('./harness.cjs');

const [mode, aerovo, frames, focal, heightM, runDir] = process.argv.slice(2);
const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY };

function freePort() {
  return new Promise(resolve => {
    const s = dgram.createSocket('udp4');
    s.bind(0, '127.0.0.1', () => { const p = s.address().port; s.close(() => resolve(p)); });
  });
}

async function main() {
  const got = { odometry: [], heartbeats: [], timesync: [], gpsInput: 0 };
  const signing = mode === 'signed';
  const key = crypto.randomBytes(32);
  const signatures = { total: 0, unsigned: 0, bad: 0, backwards: 0, last: new Map() };
  // The tick at which the first packet of aerovo arrived (its socket is bound and has heard the
  // fake autopilot's genuine stream): the hostile packets start only after it.
  let heardAtTick = null;
  let tick = 0;
  const { sock, splitter, port: myPort } = await listen(packet => {
    if (heardAtTick === null) heardAtTick = tick;
    ++signatures.total;
    const sig = packet.signature;
    if (!sig) {
      ++signatures.unsigned;
    } else {
      if (!sig.matches(key)) ++signatures.bad;
      const stream = `${packet.header.sysid}/${packet.header.compid}/${sig.linkId}`;
      const last = signatures.last.get(stream);
      if (last !== undefined && !(sig.timestamp > last)) ++signatures.backwards;
      signatures.last.set(stream, sig.timestamp);
    }
    const clazz = REGISTRY[packet.header.msgid];
    if (!clazz) return;
    const data = packet.protocol.data(packet.payload, clazz);
    if (packet.header.msgid === common.Odometry.MSG_ID) got.odometry.push({ h: packet.header, d: data });
    if (packet.header.msgid === minimal.Heartbeat.MSG_ID) got.heartbeats.push({ h: packet.header, d: data });
    if (packet.header.msgid === common.TimeSync.MSG_ID) got.timesync.push({ h: packet.header, d: data });
    if (packet.header.msgid === common.GpsInput.MSG_ID) ++got.gpsInput;
  });

  const args = ['run', frames, '--focal-px', focal, '--out', runDir, '-q', '--no-report'];
  if (signing) {
    const keyFile = path.join(path.dirname(runDir), 'mavlink-key-signed.hex');
    fs.rmSync(keyFile, { force: true });
    fs.rmSync(keyFile + '.timestamp', { force: true });
    fs.writeFileSync(keyFile, key.toString('hex') + '\n', { mode: 0o600 });
    args.push('--mavlink-key', keyFile);
  }
  let aerovoPort = myPort;
  let timer = null;
  if (mode === 'udp') {
    args.push('--altitude', heightM, '--mavlink', `udp:127.0.0.1:${myPort}`, '--mavlink-sysid', '3',
              '--mavlink-gps-input');
  } else {
    aerovoPort = await freePort();
    args.push('--mavlink', `udpin:127.0.0.1:${aerovoPort}`);
    // The fake autopilot (sysid 1, compid 1): rangefinder and attitude at 50 Hz, TIMESYNC at 10 Hz
    // (a short run on an idle machine lasts a fraction of a second).
    const proto = new MavLinkProtocolV2(1, 1);
    const signer = new MavLinkProtocolV2(1, 1, MavLinkProtocolV2.IFLAG_SIGNED);
    let seq = 0;
    // Signing timestamps in Unix ms for node-mavlink's sign(): at least 1 ms (100 units) apart,
    // since a stream's timestamps must increase from packet to packet.
    let lastMs = 0;
    const signedBytes = (m, withKey) => {
      lastMs = Math.max(Date.now(), lastMs + 1);
      return signer.sign(signer.serialize(m, seq++ & 255), 0, withKey, lastMs);
    };
    const raw = b => sock.send(b, aerovoPort, '127.0.0.1');
    const send = m => raw(signing ? signedBytes(m, key) : proto.serialize(m, seq++ & 255));
    const distance = cm => {
      const ds = new common.DistanceSensor();
      ds.timeBootMs = 0; ds.minDistance = 20; ds.maxDistance = 20000;
      ds.currentDistance = cm; ds.type = 0; ds.id = 0;
      ds.orientation = 25; ds.covariance = 255; ds.horizontalFov = 0; ds.verticalFov = 0;
      ds.quaternion = [0, 0, 0, 0]; ds.signalQuality = 0;
      return ds;
    };
    const goodCm = Math.round(Number(heightM) * 100);
    // Signed with the key before anything else is sent, sent later: older than its stream.
    const captured = signing ? signedBytes(distance(2 * goodCm), key) : null;
    let lastGood = null;
    timer = setInterval(() => {
      const ds = distance(goodCm);
      ds.timeBootMs = tick * 20;
      // A signed stream new to the receiver is accepted from any recent timestamp (MAVLink
      // signing, https://mavlink.io/en/guide/message_signing.html "Accepting Incoming
      // Packets"), so the captured packet is a replay only once aerovo has heard genuine ones:
      // under a sanitizer the run may bind its socket after the first ticks were sent.
      const hostile = signing && heardAtTick !== null && tick >= heardAtTick + 2;
      if (signing) {
        if (hostile && tick % 10 === 3) raw(lastGood);  // a replay of the last genuine one
        if (hostile && tick % 10 === 5) raw(signedBytes(distance(3 * goodCm), crypto.randomBytes(32)));  // forged
        if (hostile && tick % 10 === 7) raw(proto.serialize(distance(4 * goodCm), seq++ & 255));  // unsigned
        if (hostile && tick % 10 === 9) raw(captured);
        lastGood = signedBytes(ds, key);
        raw(lastGood);
      } else {
        send(ds);
      }
      const at = new common.Attitude();
      at.timeBootMs = tick * 20; at.roll = 0.05; at.pitch = -0.025; at.yaw = 0.5;
      at.rollspeed = 0; at.pitchspeed = 0; at.yawspeed = 0;
      send(at);
      if (tick % 5 === 0) {
        const ts = new common.TimeSync();
        ts.tc1 = 0n; ts.ts1 = BigInt(1000 + tick); ts.targetSystem = 0; ts.targetComponent = 0;
        send(ts);
      }
      ++tick;
    }, 20);
  }
  if (signing) {
    // A key file others may read is bad input (exit 1), named in the error, before any frame.
    const loose = path.join(path.dirname(runDir), 'mavlink-key-loose.hex');
    fs.rmSync(loose, { force: true });
    fs.writeFileSync(loose, key.toString('hex') + '\n', { mode: 0o644 });
    fs.chmodSync(loose, 0o644);
    const bad = args.map(a => (a.endsWith('mavlink-key-signed.hex') ? loose : a === runDir ? runDir + '-loose' : a));
    fs.rmSync(runDir + '-loose', { recursive: true, force: true });
    const r = spawnSync(aerovo, bad, { encoding: 'utf8' });
    check(r.status === 1, `a mode 644 key file: exit ${r.status}, expected 1`);
    check(r.stderr.includes(loose) && r.stderr.includes('chmod 600'), `a mode 644 key file: ${r.stderr.trim()}`);
  }
  const code = await runAerovo(aerovo, args);
  if (timer) clearInterval(timer);
  sock.close();
  check(code === 0, `aerovo exited with ${code}`);
  if (code !== 0) return;

  const rows = readCsv(path.join(runDir, 'frames.csv'));
  const summary = JSON.parse(fs.readFileSync(path.join(runDir, 'summary.json'), 'utf8'));
  check(rows.length === summary.frames_processed, `frames.csv has ${rows.length} rows, summary ${summary.frames_processed}`);
  check(splitter.invalidPackages === 0, `${splitter.invalidPackages} packets with a bad CRC`);
  const odo = got.odometry;
  check(odo.length === rows.length, `${odo.length} ODOMETRY for ${rows.length} processed frames`);
  let resets = 0, reacquired = 0, bridged = 0;
  for (let i = 0; i < Math.min(odo.length, rows.length); ++i) {
    const d = odo[i].d, r = rows[i];
    if (i > 0) check(d.timeUsec > odo[i - 1].d.timeUsec, `frame ${i}: time_usec ${d.timeUsec} not after ${odo[i - 1].d.timeUsec}`);
    check(d.frameId === 20 && d.childFrameId === 12, `frame ${i}: frame ids ${d.frameId}/${d.childFrameId}`);
    check(d.estimatorType === 2, `frame ${i}: estimator_type ${d.estimatorType}`);
    check(Math.abs(d.x - Number(r.y_m)) <= 1e-3, `frame ${i}: x ${d.x} vs frames.csv y_m ${r.y_m}`);
    check(Math.abs(d.y - Number(r.x_m)) <= 1e-3, `frame ${i}: y ${d.y} vs frames.csv x_m ${r.x_m}`);
    const isBridged = r.status.startsWith('bridged');
    check(isBridged === (d.quality === -1), `frame ${i}: status ${r.status}, quality ${d.quality}`);
    if (r.status === 'reacquired') ++reacquired;
    if (isBridged) ++bridged;
    const prev = i > 0 ? odo[i - 1].d.resetCounter : 0;
    const expect = r.status === 'reacquired' ? prev + 1 : prev;
    check(d.resetCounter === expect, `frame ${i} (${r.status}): reset_counter ${d.resetCounter}, expected ${expect}`);
    resets = d.resetCounter;
  }
  const hb = got.heartbeats;
  check(hb.length >= 1, 'no HEARTBEAT');
  if (hb.length) {
    check(hb[0].h.compid === 197, `HEARTBEAT compid ${hb[0].h.compid}`);
    check(hb[0].d.type === 18, `HEARTBEAT type ${hb[0].d.type}`);
  }
  if (mode === 'udp') {
    check(hb.length === 0 || hb[0].h.sysid === 3, `HEARTBEAT sysid ${hb.length && hb[0].h.sysid}`);
    check(odo.length === 0 || odo[0].h.sysid === 3, 'ODOMETRY sysid');
    check(reacquired >= 1 && bridged >= 1, `the flight must bridge and re-acquire (bridged ${bridged}, reacquired ${reacquired})`);
    check(resets === reacquired, `final reset_counter ${resets}, ${reacquired} re-acquired frames`);
    const g = (summary.mavlink || {}).gps_input;
    check(got.gpsInput === 0, `${got.gpsInput} GPS_INPUT sent for a track that is not geo-referenced`);
    check(g && g.sent === 0 && g.with_fix === 0, `summary.json mavlink.gps_input ${JSON.stringify(g)}: none sent`);
  } else {
    const want = Number(heightM);
    rows.forEach((r, i) => {
      check(r.height_source === 'mavlink_distance_sensor', `frame ${i}: height_source ${r.height_source}`);
      check(Math.abs(Number(r.height_m) - want) < 1e-6, `frame ${i}: height_m ${r.height_m}`);
      check(Math.abs(Number(r.roll_deg) - 0.05 * 180 / Math.PI) < 1e-3, `frame ${i}: roll_deg ${r.roll_deg}`);
      check(Math.abs(Number(r.pitch_deg) + 0.025 * 180 / Math.PI) < 1e-3, `frame ${i}: pitch_deg ${r.pitch_deg}`);
    });
    check(summary.height_source === 'mavlink', `summary height_source ${summary.height_source}`);
    check(summary.height_sources && summary.height_sources.mavlink_distance_sensor === rows.length,
      `summary height_sources ${JSON.stringify(summary.height_sources)}`);
    check(summary.mavlink && summary.mavlink.distance_samples > 0, 'summary mavlink.distance_samples');
    const m = summary.mavlink || {};
    if (signing) {
      check(m.signing === true, `summary mavlink.signing ${m.signing}`);
      check(m.signed_accepted > 0, `summary mavlink.signed_accepted ${m.signed_accepted}`);
      check(m.rejected_bad_signature >= 1, `summary mavlink.rejected_bad_signature ${m.rejected_bad_signature}`);
      check(m.rejected_unsigned >= 1, `summary mavlink.rejected_unsigned ${m.rejected_unsigned}`);
      check(m.rejected_replayed >= 2, `summary mavlink.rejected_replayed ${m.rejected_replayed} (a replay and a captured packet)`);
      check(signatures.total > 0 && signatures.unsigned === 0, `${signatures.unsigned} of aerovo's ${signatures.total} packets unsigned`);
      check(signatures.bad === 0, `${signatures.bad} of aerovo's packets with a signature node-mavlink rejects`);
      check(signatures.backwards === 0, `${signatures.backwards} of aerovo's signing timestamps not after the previous one`);
      // The signing timestamp kept across runs, beside the key: at least the last one sent.
      const tsFile = path.join(path.dirname(runDir), 'mavlink-key-signed.hex.timestamp');
      const kept = fs.existsSync(tsFile) ? fs.readFileSync(tsFile, 'utf8') : '';
      const lastSent = [...signatures.last.values()].reduce((a, b) => (b > a ? b : a), 0n);
      check(/^\d+\n$/.test(kept) && BigInt(kept.trim()) >= BigInt(lastSent),
        `signing timestamp file ${tsFile}: '${kept.trim()}', last sent ${lastSent}`);
      check(m.signing_timestamp_saves >= 1 && m.signing_timestamp_save_failed === 0,
        `summary mavlink.signing_timestamp_saves ${m.signing_timestamp_saves}, failed ${m.signing_timestamp_save_failed}`);
    } else {
      check(m.signing === false && m.rejected_unsigned === 0, `summary mavlink signing ${m.signing}, rejected_unsigned ${m.rejected_unsigned}`);
      check(signatures.total > 0 && signatures.unsigned === signatures.total, 'aerovo signed without a key');
    }
    const answers = got.timesync.filter(t => t.d.tc1 !== 0n);
    check(answers.length >= 1, 'no TIMESYNC answer');
    if (answers.length) {
      check(answers[0].d.ts1 >= 1000n, `TIMESYNC ts1 ${answers[0].d.ts1} not echoed`);
      check(answers[0].d.targetSystem === 1 && answers[0].d.targetComponent === 1, 'TIMESYNC target');
    }
  }
  console.log(`${mode}: ${odo.length} ODOMETRY, ${hb.length} HEARTBEAT, ${got.timesync.length} TIMESYNC for ${rows.length} frames`);
}

finish(main, 30);
