// aerovo reading a LIVE stream, its vision messages put through ArduPilot's and PX4's arithmetic
// (the checks of autopilots.cjs, decoded by node-mavlink, never by aerovo's code).
//   node live.cjs AEROVO STREAM FOCAL_PX HEIGHT_M SPEED_MPS RUN_DIR
// STREAM: an MPEG-TS file of the simulated straight flight of autopilots.cjs (a black frame
// mid-flight: bridged, then re-acquired) that ffmpeg plays at its own pace (-re) to
// udp://127.0.0.1:PORT, where `aerovo run udp://127.0.0.1:PORT?timeout=2000000 --mavlink
// udp:...` reads it as a live source (docs/inputs.md: the stream's presentation times are the
// frames' times; frames that come faster than they are processed are dropped, and frames.csv
// lists those processed). Once for ODOMETRY, once for VISION_POSITION_ESTIMATE: no NaN or
// out-of-range value reaching either estimator, positions equal to frames.csv within 1 mm,
// timestamps 1 ms from the frames' own time differences (or up to 0.1 s shorter where a frame
// that came with less delay than all before moved the live clock earlier: autopilots.cjs
// clockSlack), velocities (from the frames' own times) within 5 % of SPEED_MPS.
// The stream's probe is kept short (OPENCV_FFMPEG_CAPTURE_OPTIONS, OpenCV's FFmpeg capture
// options: 0.1 s, 32 kB) so that the first frames are not held back as a burst; the udp
// protocol's `timeout` (microseconds) ends the run 2 s after the stream stops.
// Exit 0 = pass, 1 = fail (the reasons printed).
'use strict';
const dgram = require('dgram');
const path = require('path');
const { spawn } = require('child_process');
const { minimal } = require('node-mavlink');
const { check, readCsv, listen, runAerovo, finish } = require('./harness.cjs');
const { REGISTRY, odometry, positionEstimate, clockSlack } = require('./autopilots.cjs');

// The live clock's corrections allowed (autopilots.cjs clockSlack): 0.1 s, against the 0.25 s
// between frames; the largest seen is printed.
clockSlack.s = 0.1;

const [aerovo, stream, focal, heightM, , runRoot] = process.argv.slice(2);

// A free UDP port of 127.0.0.1 (bound, then released for aerovo's stream).
async function freePort() {
  const s = dgram.createSocket('udp4');
  await new Promise(r => s.bind(0, '127.0.0.1', r));
  const port = s.address().port;
  await new Promise(r => s.close(r));
  return port;
}

// ffmpeg playing STREAM to the port at real-time pace; resolves to its exit code.
function play(port) {
  const args = ['-loglevel', 'error', '-re', '-i', stream, '-c', 'copy', '-f', 'mpegts',
                `udp://127.0.0.1:${port}?pkt_size=1316`];
  const child = spawn('ffmpeg', args, { stdio: ['ignore', 'inherit', 'inherit'] });
  return new Promise(r => child.on('exit', c => r(c)));
}

async function runLive(kind) {
  const runDir = path.join(runRoot, kind);
  const msgs = [];
  const { sock, splitter, port } = await listen(packet => {
    const clazz = REGISTRY[packet.header.msgid];
    if (!clazz || packet.header.msgid === minimal.Heartbeat.MSG_ID) return;
    msgs.push(packet.protocol.data(packet.payload, clazz));
  });
  const streamPort = await freePort();
  process.env.OPENCV_FFMPEG_CAPTURE_OPTIONS = 'analyzeduration;100000|probesize;32768';
  const args = ['run', `udp://127.0.0.1:${streamPort}?timeout=2000000`, '--focal-px', focal,
                '--altitude', heightM, '--out', runDir, '-q', '--no-report',
                '--mavlink', `udp:127.0.0.1:${port}`, '--mavlink-message', kind];
  const run = runAerovo(aerovo, args);
  // aerovo opens the stream's socket as it starts; the stream begins 1 s later.
  await new Promise(r => setTimeout(r, 1000));
  const played = await play(streamPort);
  const code = await run;
  sock.close();
  check(played === 0, `${kind}: ffmpeg exited with ${played}`);
  check(code === 0, `${kind}: aerovo exited with ${code}`);
  check(splitter.invalidPackages === 0, `${kind}: ${splitter.invalidPackages} packets with a bad CRC`);
  const rows = code === 0 ? readCsv(path.join(runDir, 'frames.csv')) : [];
  check(msgs.length === rows.length, `${kind}: ${msgs.length} messages for ${rows.length} frames`);
  check(rows.length >= 15, `${kind}: only ${rows.length} frames of the stream processed`);
  console.log(`${kind}: ${rows.length} frames processed of the live stream`);
  return { msgs, rows };
}

async function main() {
  odometry(await runLive('odometry'));
  positionEstimate(await runLive('vision_position_estimate'));
  console.log(`live clock: timestamps up to ${(1000 * clockSlack.used).toFixed(1)} ms earlier than the frames' own differences`);
}

finish(main, 40);
