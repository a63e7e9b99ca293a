# board.sh: sourced by the selftest scripts. start_board OUT ERR ARGS...: starts the virtual
# board (ARGS: its command line; no reset by the open, no bootloader) in the background, stdout to OUT and stderr to ERR, and waits
# at most 30 s (a loaded machine) for its whole pty line; sets board_pid and board_pty, and stops
# the board if the script exits early (clear the trap once it has been waited for).
start_board() {
  local out=$1 err=$2
  shift 2
  "$@" --no-auto-reset --no-bootloader >"$out" 2>"$err" &  # the test programs run from reset
  board_pid=$!
  trap 'kill "$board_pid" 2>/dev/null || true' EXIT
  for _ in $(seq 600); do
    grep -q '^pty: .*' "$out" 2>/dev/null && [ "$(tail -c 1 "$out" | od -An -c | tr -d ' ')" = '\n' ] && break
    kill -0 "$board_pid" 2>/dev/null || break
    sleep 0.05
  done
  board_pty=$(sed -n 's/^pty: //p' "$out")
  [ -n "$board_pty" ] || { echo "no pty line"; cat "$err"; return 1; }
}
