# Sourced by examples/real/run.sh and no-depth.sh: kitchen_video KITCHEN OUT
# writes OUT/video/NNNNN.jpg, every 10th colour frame of the 7-Scenes
# recording (a camera without poses, as far as mr knows), and
# OUT/kitchen.cameramodel, 7-Scenes' nominal colour intrinsics
# (camera-intrinsics.txt).
kitchen_video() {
  local kitchen=$1 out=$2 i
  mkdir -p "$out/video"
  for i in $(seq 0 29); do
    cp "$kitchen/frame-$(printf %06d $((10 * i))).color.jpg" "$out/video/$(printf %05d "$i").jpg"
  done
  cat > "$out/kitchen.cameramodel" <<'CAM'
# 7-Scenes nominal colour intrinsics (camera-intrinsics.txt)
{
    'lensmodel':  'LENSMODEL_PINHOLE',
    'intrinsics': [ 585, 585, 320, 240, ],
    'imagersize': [ 640, 480, ],
    'extrinsics': [ 0, 0, 0, 0, 0, 0, ],
}
CAM
}
