// mcapcheck reads an MCAP file with the official Go library (github.com/foxglove/mcap/go/mcap)
// and prints what it found as JSON: a reader we did not write, for the interop tests.
// Exit 1 when the file does not read: bad magic, bad records, no summary, unreadable messages.
package main

import (
	"encoding/json"
	"errors"
	"fmt"
	"io"
	"os"

	"github.com/foxglove/mcap/go/mcap"
)

type report struct {
	Profile  string            `json:"profile"`
	Messages map[string]int    `json:"messages"`
	Schemas  map[string]string `json:"schemas"`
	Metadata map[string]map[string]string `json:"metadata"`
	Chunks   int               `json:"chunks"`
	Summary  bool              `json:"summary"`
	Stats    uint64            `json:"statistics_message_count"`
}

func fail(format string, args ...any) {
	fmt.Fprintf(os.Stderr, "mcapcheck: "+format+"\n", args...)
	os.Exit(1)
}

func main() {
	if len(os.Args) != 2 {
		fail("usage: mcapcheck FILE.mcap")
	}
	f, err := os.Open(os.Args[1])
	if err != nil {
		fail("%v", err)
	}
	defer f.Close()
	reader, err := mcap.NewReader(f)
	if err != nil {
		fail("reader: %v", err)
	}
	rep := report{Messages: map[string]int{}, Schemas: map[string]string{}, Metadata: map[string]map[string]string{}}
	rep.Profile = reader.Header().Profile
	info, err := reader.Info()
	if err != nil {
		fail("info (summary section): %v", err)
	}
	rep.Summary = true
	rep.Chunks = len(info.ChunkIndexes)
	if info.Statistics != nil {
		rep.Stats = info.Statistics.MessageCount
	}
	for _, idx := range info.MetadataIndexes {
		md, err := reader.GetMetadata(idx.Offset)
		if err != nil {
			fail("metadata %s: %v", idx.Name, err)
		}
		rep.Metadata[md.Name] = md.Metadata
	}
	it, err := reader.Messages(mcap.UsingIndex(true), mcap.InOrder(mcap.LogTimeOrder))
	if err != nil {
		fail("messages: %v", err)
	}
	for {
		schema, channel, msg, err := it.NextInto(nil)
		if errors.Is(err, io.EOF) {
			break
		}
		if err != nil {
			fail("message: %v", err)
		}
		if len(msg.Data) == 0 {
			fail("empty message on %s", channel.Topic)
		}
		var v any
		if channel.MessageEncoding == "json" {
			if err := json.Unmarshal(msg.Data, &v); err != nil {
				fail("message on %s is not JSON: %v", channel.Topic, err)
			}
		}
		rep.Messages[channel.Topic]++
		if schema != nil {
			rep.Schemas[channel.Topic] = schema.Name + " (" + schema.Encoding + ")"
		}
	}
	if uint64(total(rep.Messages)) != rep.Stats {
		fail("statistics say %d messages, read %d", rep.Stats, total(rep.Messages))
	}
	out, _ := json.Marshal(rep)
	fmt.Println(string(out))
}

func total(m map[string]int) int {
	n := 0
	for _, c := range m {
		n += c
	}
	return n
}
