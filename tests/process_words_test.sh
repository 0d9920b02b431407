#!/usr/bin/env bash
# The tracked text describes the product, not how it was developed: no numbered work stops
# ("stop 32", "this stop"), no issue numbers ("issue 14": they belong in commit messages), no
# helpers or agents who built or measured something, no "I" as the author, no work sessions.
# Product words stay allowed: a viewer's WebSocket session ("this session's reply"), a C++
# helper function or thread ("std::thread helper", "helpers that read the page"), lines that
# "stop at the boundary".
#
# Scans every file `git ls-files` lists (outside a git checkout: every file under the source
# tree but build/ and .git/), skipping binary files, tests/browser/node_modules and this
# script. Prints every hit as path:line:text and exits 1 if there is any; otherwise prints
# "process words: 0 hits in N files" and exits 0.
#   tests/process_words_test.sh [SOURCE_DIR]
set -euo pipefail

root="${1:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}"
cd "$root"
self="tests/process_words_test.sh"

# Case-insensitive, except the author's "I" and "my", which must be capitalised as written.
pattern='(?i)'
pattern+='\bstops? ?#?[0-9]+\b'                                  # stop 32, stops 32 and 35
pattern+='|\b(this|last|previous|next) stop\b'                   # this stop, the last stop
pattern+='|\b(last|previous) \w+ stops\b'                         # the last five stops
pattern+='|\bstops? (later|earlier|ago)\b'                       # two stops ago
pattern+='|\bissue ?#?[0-9]+\b|\bissues #?[0-9]+ (and|or|to) #?[0-9]+\b'  # issue 14, issues 13 and 17
pattern+='|\b(this|the) issue'"'"'s\b|\bthis issue\b'              # the issue's own table
pattern+='|\bhelpers'"'"'|\bhelper agents?\b|\bother helpers?\b'   # other helpers' builds
pattern+='|\b(a|another|the) helper (reviewed|ran|built|measured|found|wrote)\b'
pattern+='|\bthe coordinator\b'
pattern+='|\b(next|previous) session\b|\bthis session\b(?!'"'"')|\bsession'"'"'s time\b'
pattern+='|(?-i:\bI (cannot|can'"'"'t|could not|tried|measured|found|think|had|wrote|looked|kept|chose|checked|ran|recorded)\b)'
pattern+='|(?-i:\b[Mm]y (own )?(build|run|measurement|change|session|test)s?\b)'

files=()
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  while IFS= read -r -d '' f; do files+=("$f"); done < <(git ls-files -z)
else
  while IFS= read -r -d '' f; do files+=("${f#./}"); done \
    < <(find . -type f -not -path './build/*' -not -path './.git/*' -print0)
fi

scan=()
for f in "${files[@]}"; do
  case "$f" in
    "$self" | tests/browser/node_modules/*) continue ;;
  esac
  [[ -f "$f" ]] && scan+=("$f")
done

# text files only: grep -I treats a binary file as matching nothing
text_count=0
hits=""
if ((${#scan[@]})); then
  text_count=$(printf '%s\0' "${scan[@]}" | xargs -0 grep -I -l -e '' -- 2>/dev/null | wc -l)
  hits=$(printf '%s\0' "${scan[@]}" | xargs -0 grep -I -n -H -P -e "$pattern" -- 2>/dev/null || true)
fi

if [[ -n "$hits" ]]; then
  printf '%s\n' "$hits"
  echo "process words: $(printf '%s\n' "$hits" | wc -l) hits in $text_count files" >&2
  exit 1
fi
echo "process words: 0 hits in $text_count files"
