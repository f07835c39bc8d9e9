// aerovo's .tlog reader on a MAVLink telemetry log a ground station recorded (not one a test
// wrote): node-mavlink's examples/vtol.tlog, installed with the package (run_e2e.sh), read here
// by node-mavlink's own tlog splitter and parser, never by aerovo's code.
//   node tlog.cjs AEROVO TLOG
// What aerovo's reader must give (src/aerovo/telemetry/tlog_reader.cc, docs/inputs.md "MAVLink
// telemetry logs (.tlog)"), computed here independently from the decoded packets:
//  - the vehicle: the first system whose component 1 sent a HEARTBEAT with an autopilot type
//    other than MAV_AUTOPILOT_INVALID (8);
//  - one sample per GLOBAL_POSITION_INT of it with a fix (not lat = lon = 0, and the latest
//    GPS_RAW_INT before it, in the file's order, with fix_type >= 3), in the order of the
//    autopilot's time_boot_ms (the log's link delivers some late), a time received twice once;
//  - time_s = time_boot_ms / 1000 (no reboot in this log: checked), lat/lon = degE7 / 1e7,
//    abs_alt = alt / 1000, rel_alt = relative_alt / 1000, all to the printed precision;
//  - yaw: ATTITUDE.yaw interpolated at the sample's time along the shorter arc, in [0, 360);
//  - a warning counting the positions that arrived after a later one.
// Exit 0 = pass, 1 = fail (the reasons printed).
'use strict';
const fs = require('fs');
const { spawnSync } = require('child_process');
const { MavLinkTLogPacketSplitter, MavLinkPacketParser, minimal, common } = require('node-mavlink');
const { failures, check, finish } = require('./harness.cjs');

const [aerovo, tlog] = process.argv.slice(2);
const MAV_AUTOPILOT_INVALID = 8;

// Every packet of the file in its order, decoded by node-mavlink (its splitter checks the CRC).
// The file is given as one buffer: read as a stream of 64 KiB chunks, node-mavlink 2.3.0's
// splitter loses the GLOBAL_POSITION_INT record that straddles byte 917504 (14 x 65536) of
// vtol.tlog, whose CRC is right.
async function readPackets(file) {
  const splitter = new MavLinkTLogPacketSplitter();
  const parser = splitter.pipe(new MavLinkPacketParser());
  const packets = [];
  parser.on('data', p => packets.push(p));
  const done = new Promise(r => parser.on('end', r));
  splitter.end(fs.readFileSync(file));
  await done;
  return { packets, invalid: splitter.invalidPackages };
}

const data = (p, clazz) => p.protocol.data(p.payload, clazz);

// The shorter-arc difference a - b of two angles in degrees, in [-180, 180].
const angleDiff = (a, b) => { const d = ((a - b) % 360 + 540) % 360 - 180; return d; };

async function main() {
  check(fs.existsSync(tlog), `no ${tlog}: node-mavlink's examples are not installed`);
  const { packets, invalid } = await readPackets(tlog);
  check(packets.length > 10000, `only ${packets.length} packets decoded from ${tlog}`);
  let vehicle;
  for (const p of packets) {
    if (p.header.msgid === minimal.Heartbeat.MSG_ID && p.header.compid === 1) {
      const h = data(p, minimal.Heartbeat);
      if (h.autopilot !== MAV_AUTOPILOT_INVALID) { vehicle = p.header.sysid; break; }
    }
  }
  if (!check(vehicle !== undefined, 'no autopilot HEARTBEAT in the log')) return;
  let fix;
  const positions = [];
  const attitude = [];
  let late = 0, maxLag = 0, latest = -Infinity;
  for (const p of packets) {
    if (p.header.sysid !== vehicle || p.header.compid !== 1) continue;
    if (p.header.msgid === common.GpsRawInt.MSG_ID) {
      fix = data(p, common.GpsRawInt).fixType;
    } else if (p.header.msgid === common.Attitude.MSG_ID) {
      const a = data(p, common.Attitude);
      attitude.push({ t: a.timeBootMs / 1000, yaw: a.yaw * 180 / Math.PI });
    } else if (p.header.msgid === common.GlobalPositionInt.MSG_ID) {
      const g = data(p, common.GlobalPositionInt);
      if ((g.lat === 0 && g.lon === 0) || (fix !== undefined && fix < 3)) continue;
      const t = g.timeBootMs / 1000;
      if (t < latest) { ++late; maxLag = Math.max(maxLag, latest - t); }
      latest = Math.max(latest, t);
      positions.push({ t, lat: g.lat / 1e7, lon: g.lon / 1e7, alt: g.alt / 1000, rel: g.relativeAlt / 1000 });
    }
  }
  // No reboot: time_boot_ms never falls by more than the link's reordering (a few seconds).
  check(positions.every((p, i) => i === 0 || p.t > positions[i - 1].t - 5),
    'the log has a reboot: this test assumes time_s = time_boot_ms / 1000');
  // The class the test is for: this log's link delivered positions late.
  check(late > 0, 'no GLOBAL_POSITION_INT arrived after a later one: the log no longer tests reordering');
  const expected = positions.slice().sort((a, b) => a.t - b.t)
    .filter((p, i, all) => i === 0 || p.t !== all[i - 1].t);
  attitude.sort((a, b) => a.t - b.t);

  const run = spawnSync(aerovo, ['telemetry', '--print', tlog], { encoding: 'utf8' });
  process.stderr.write(run.stderr);
  if (!check(run.status === 0, `aerovo telemetry exited with ${run.status}`)) return;
  const lines = run.stdout.split('\n');
  const head = lines.findIndex(l => l.startsWith('time_s,'));
  if (!check(head >= 0, 'no CSV header in `aerovo telemetry --print`')) return;
  const cols = lines[head].split(',');
  const rows = lines.slice(head + 1).filter(l => l).map(l => {
    const c = l.split(','); const r = {};
    cols.forEach((h, i) => { r[h] = c[i]; });
    return r;
  });
  check(rows.length === expected.length,
    `${rows.length} samples read, ${expected.length} GLOBAL_POSITION_INT with a fix in the log`);
  const warning = `${late} GLOBAL_POSITION_INT message(s) of the autopilot (system ${vehicle}) arrived after later ones (by up to ${maxLag.toFixed(3)} s`;
  check(run.stderr.includes(warning), `no warning "${warning}"`);

  let yawChecked = 0;
  for (let i = 0; i < Math.min(rows.length, expected.length); ++i) {
    const r = rows[i], e = expected[i];
    const near = (name, got, want, tol) =>
      check(Math.abs(got - want) <= tol, `sample ${i}: ${name} ${got}, expected ${want}`);
    near('time_s', Number(r.time_s), e.t, 0.0005);
    near('lat_deg', Number(r.lat_deg), e.lat, 0.6e-8);
    near('lon_deg', Number(r.lon_deg), e.lon, 0.6e-8);
    near('abs_alt_m', Number(r.abs_alt_m), e.alt, 0.0006);
    near('rel_alt_m', Number(r.rel_alt_m), e.rel, 0.0006);
    // ATTITUDE around the sample, at most 1 s apart (aerovo does not interpolate over longer gaps).
    const k = attitude.findIndex(a => a.t >= e.t);
    if (k > 0 && attitude[k].t - attitude[k - 1].t <= 1.0) {
      const a = attitude[k - 1], b = attitude[k];
      const w = (e.t - a.t) / (b.t - a.t);
      const want = ((a.yaw + w * angleDiff(b.yaw, a.yaw)) % 360 + 360) % 360;
      const got = Number(r.yaw_deg);
      check(got >= 0 && got < 360, `sample ${i}: yaw_deg ${got} outside [0, 360)`);
      check(Math.abs(angleDiff(got, want)) <= 0.006, `sample ${i}: yaw_deg ${got}, expected ${want.toFixed(3)}`);
      ++yawChecked;
    }
  }
  check(yawChecked > 0.9 * expected.length, `yaw checked on only ${yawChecked} of ${expected.length} samples`);
  console.log(`${tlog}: ${packets.length} packets (${invalid} invalid), vehicle system ${vehicle}, ` +
    `${expected.length} positions with a fix (${late} late, up to ${maxLag.toFixed(3)} s), ` +
    `${yawChecked} yaws checked`);
}

finish(main, 20);
