// capsflow command line: placeholder until the CLI lands.
#include <cstdio>
int main() {
  std::puts("capsflow");
  return 0;
}
