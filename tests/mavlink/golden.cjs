// Prints the golden packets of src/aerovo/mavlink/messages_test.cc, serialised by node-mavlink
// (an implementation independent of aerovo's, generated from the same XML definitions). Run
// once by hand after `npm ci` in a folder with this package.json:
//   NODE_PATH=<that folder>/node_modules node tests/mavlink/golden.cjs
// The field values are chosen exactly representable in float32, so the C++ test can set the
// same ones.
'use strict';
const { MavLinkProtocolV2, minimal, common, ardupilotmega } = require('node-mavlink');

function hex(msg, seq, sysid, compid) {
  const p = new MavLinkProtocolV2(sysid, compid);
  return p.serialize(msg, seq).toString('hex');
}
const iota = (n, a, b) => Array.from({ length: n }, (_, i) => a + b * i);

const hb = new minimal.Heartbeat();
hb.type = 18; hb.autopilot = 8; hb.baseMode = 0; hb.customMode = 0; hb.systemStatus = 4;
hb.mavlinkVersion = 3;
console.log('heartbeat', hex(hb, 7, 42, 197));

const odo = new common.Odometry();
odo.timeUsec = 1234567890123n; odo.frameId = 20; odo.childFrameId = 12;
odo.x = 1.5; odo.y = -2.25; odo.z = 0.125; odo.q = [1, 0, 0, 0.5];
odo.vx = 3; odo.vy = -4; odo.vz = 0.5; odo.rollspeed = NaN; odo.pitchspeed = NaN; odo.yawspeed = 0.25;
odo.poseCovariance = iota(21, 0.5, 0.25); odo.poseCovariance[11] = NaN;
odo.velocityCovariance = iota(21, -1, 0.125);
odo.resetCounter = 3; odo.estimatorType = 2; odo.quality = -1;
console.log('odometry', hex(odo, 200, 1, 197));

// Extensions all zero and the last base fields zero: truncated below the MAVLink 1 length.
const odo0 = new common.Odometry();
odo0.timeUsec = 5n; odo0.frameId = 0; odo0.childFrameId = 0; odo0.x = 1; odo0.q = [0, 0, 0, 0];
odo0.poseCovariance = iota(21, 0, 0); odo0.velocityCovariance = iota(21, 0, 0);
odo0.resetCounter = 0; odo0.estimatorType = 0; odo0.quality = 0;
console.log('odometry_truncated', hex(odo0, 0, 1, 197));

const vpe = new common.VisionPositionEstimate();
vpe.usec = 987654321n; vpe.x = -1; vpe.y = 2; vpe.z = -0.5; vpe.roll = 0.0625; vpe.pitch = -0.125;
vpe.yaw = 3; vpe.covariance = iota(21, 1, 1); vpe.resetCounter = 9;
console.log('vision_position_estimate', hex(vpe, 1, 1, 197));

const vpd = new ardupilotmega.VisionPositionDelta();
vpd.timeUsec = 1000000n; vpd.timeDeltaUsec = 33333n; vpd.angleDelta = [0, 0, -0.03125];
vpd.positionDelta = [0.75, -0.5, 0]; vpd.confidence = 87;
console.log('vision_position_delta', hex(vpd, 2, 1, 197));

const ts = new common.TimeSync();
ts.tc1 = 123456789012345n; ts.ts1 = -42n; ts.targetSystem = 255; ts.targetComponent = 190;
console.log('timesync', hex(ts, 3, 1, 197));

const ds = new common.DistanceSensor();
ds.timeBootMs = 60000; ds.minDistance = 20; ds.maxDistance = 4000; ds.currentDistance = 8123;
ds.type = 0; ds.id = 1; ds.orientation = 25; ds.covariance = 255; ds.horizontalFov = 0;
ds.verticalFov = 0; ds.quaternion = [0, 0, 0, 0]; ds.signalQuality = 0;
console.log('distance_sensor', hex(ds, 9, 1, 1));

const gp = new common.GlobalPositionInt();
gp.timeBootMs = 61000; gp.lat = 473977420; gp.lon = 85455940; gp.alt = 488000;
gp.relativeAlt = 80250; gp.vx = -120; gp.vy = 35; gp.vz = 0; gp.hdg = 27000;
console.log('global_position_int', hex(gp, 10, 1, 1));

const at = new common.Attitude();
at.timeBootMs = 62000; at.roll = 0.0625; at.pitch = -0.03125; at.yaw = 1.5; at.rollspeed = 0;
at.pitchspeed = 0; at.yawspeed = 0;
console.log('attitude', hex(at, 11, 1, 1));

const gi = new common.GpsInput();
gi.timeUsec = 1764806400123456n; gi.gpsId = 0; gi.ignoreFlags = 4 | 16 | 128;
gi.timeWeekMs = 345618123; gi.timeWeek = 2395; gi.fixType = 3; gi.lat = 435511234;
gi.lon = 71234567; gi.alt = 182.5; gi.hdop = 1; gi.vdop = 0; gi.vn = 4.75; gi.ve = -1.25;
gi.vd = 0; gi.speedAccuracy = 0.125; gi.horizAccuracy = 1.5; gi.vertAccuracy = 0;
gi.satellitesVisible = 10; gi.yaw = 36000;
console.log('gps_input', hex(gi, 12, 1, 197));

// yaw 0 (unknown): the extension is all zeros and truncated away.
const gi0 = new common.GpsInput();
gi0.timeUsec = 5n; gi0.ignoreFlags = 255; gi0.fixType = 1; gi0.lat = -335000000;
gi0.lon = -1800000000; gi0.hdop = 99.99; gi0.vdop = 99.99; gi0.yaw = 0;
console.log('gps_input_no_fix', hex(gi0, 13, 1, 197));

// Signed packets (src/aerovo/mavlink/signing_test.cc): node-mavlink's own signing, with the key
// 00 01 02 .. 1f, link id 0 and a fixed time. node-mavlink's sign() takes Unix milliseconds and
// writes (ms - 2015-01-01) * 100, the timestamp in 10 us units. The header's signed flag is set
// before serialising (the checksum covers it).
function signedHex(msg, seq, sysid, compid, linkId, unixMs) {
  const p = new MavLinkProtocolV2(sysid, compid, MavLinkProtocolV2.IFLAG_SIGNED);
  const key = Buffer.from(Array.from({ length: 32 }, (_, i) => i));
  return p.sign(p.serialize(msg, seq), linkId, key, unixMs).toString('hex');
}
console.log('distance_sensor_signed', signedHex(ds, 9, 1, 1, 0, 1764806400123));
console.log('heartbeat_signed', signedHex(hb, 7, 42, 197, 3, 1764806400124));
